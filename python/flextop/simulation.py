"""Running a scene: :class:`Simulation`, which builds it once and runs it for any design
(its results in :mod:`flextop.results`; runs to a tolerance in
:mod:`flextop.discretization`).

``Simulation(scene).run(x)`` integrates a dynamic scene with generalized-α (paper
Algorithm 1) or solves a static one, for the design ``x`` (one density per design
variable, ``None`` for full density). The engine releases the GIL while it runs.
"""

from __future__ import annotations

import copy
import difflib
import json
import math
import os
import threading
import warnings
from collections import OrderedDict
from concurrent.futures import Executor
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any, Callable, Iterable, Sequence, Union

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

from . import _core, execution, modal, plausibility, responses
from .discretization import Levels, Refined, indicator, refinement, tolerance
from .discretization.accuracy import rtol_of, run_tolerance
from .errors import DesignError, MechanismWarning, PlausibilityWarning, SceneError, SettingsError, SettingsWarning
from .io import saved
from .scenes import Scene
from .scenes.spatial import is_spatial
from .discretization.tolerance import Discretization
from .results import Bars, Joint, Results, Sensitivities, StaticResults


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
    """A :class:`MechanismWarning` naming the joints that over-constrain the rigid mechanism
    (not for rows that only repeat what undriven joints between the same two frames impose:
    those agree in every motion)."""
    if mechanism["over_constraining"]:
        names = ", ".join(f"'{n}'" for n in mechanism["over_constraining"])
        count = mechanism["redundant_rows"] - mechanism["repeated_rows"]
        warnings.warn(f"the joints {names} over-constrain the rigid mechanism ({count} redundant row(s)): "
                      "the flexible model runs, but the rigid motion (and the tip deflection, Eq. 40) exists only where "
                      "the redundant constraints agree", MechanismWarning, stacklevel=3)


def _warn_if_drives_cut_off(joints: Sequence[Joint], t_end: float) -> None:
    """A :class:`SettingsWarning` naming each drive whose motion law is still accelerating
    or braking at ``t_end``: the run ends in the middle of the motion asked for. (A law cut
    off while it cruises is the idiom of a spin-up to constant speed, and is left alone.)"""
    for joint in joints:
        if joint.drive_phases is None:
            continue
        accelerated, braking, done = joint.drive_phases
        if t_end < accelerated * (1 - 1e-9) or braking * (1 + 1e-9) < t_end < done * (1 - 1e-9):
            phase = "accelerating" if t_end < accelerated else "braking"
            warnings.warn(f"joint '{joint.name}': its motion law is still {phase} at t_end = {t_end:.4g} s (done at "
                          f"t = {done:.4g} s): the run stops in the middle of the motion; give a longer t_end to see it done",
                          SettingsWarning, stacklevel=4)


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
        spec = scene.to_dict()
    elif isinstance(scene, dict):
        spec = scene
    else:
        spec = Scene.from_toml(Path(scene)).to_dict()
    if is_spatial(spec):
        raise SceneError("dimension = 3: a spatial scene; run it with flextop.SpatialSimulation")
    return spec


REFINE = ("shares", "bars", "uniform")
"""How a run to a tolerance may refine a scene's bars (``Simulation(..., refine=...)``)."""


def design_vector(x: Any, n_design: int) -> np.ndarray | None:
    """``x`` as a vector of ``n_design`` floats: a number means every variable; strings,
    complex numbers, arrays of more than one dimension and vectors of another length are
    refused with a DesignError (values outside ``[x_min, 1]`` by the engine)."""
    if x is None:
        return None
    xv = np.asarray(x)
    if xv.dtype.kind not in "biuf":
        raise DesignError(f"the design must be real numbers, got {type(x).__name__} of {xv.dtype}")
    if xv.ndim > 1:
        raise DesignError(f"the design must be one number or a vector of {n_design}, got an array of shape {xv.shape}")
    xv = xv.astype(float)
    if xv.ndim == 0:
        return np.full(n_design, float(xv))
    if xv.shape != (n_design,):
        raise DesignError(f"the design has {xv.size} entries; the scene has {n_design} design variables")
    return np.ascontiguousarray(xv)


def design_vectors(designs: Iterable[Any], n_design: int) -> list[np.ndarray | None]:
    """Each of ``designs`` as :func:`design_vector` makes it; a bad one is named by its
    index."""
    out = []
    for k, x in enumerate(designs):
        try:
            out.append(design_vector(x, n_design))
        except DesignError as error:
            raise DesignError(f"design {k}: {error}") from None
    return out


class Simulation:
    """A validated scene, ready to run for any design.

    Parameters
    ----------
    scene:
        A :class:`Scene`, a scene dict, or the path of a TOML scene file.
    accuracy:
        ``"fast"``, ``"balanced"`` or ``"accurate"``: a named ``rtol`` (3e-2, 1e-2, 3e-3;
        :mod:`flextop.discretization.accuracy`).
    rtol, atol:
        A tolerance on the responses (relative, and absolute in their units): runs without
        an explicit ``h`` then choose the elements per bar and the step so that the
        estimated error of every response asked for is at most ``rtol·|f| + atol``
        (:mod:`flextop.discretization.tolerance`). Each run may also pass its own.
    refine:
        How a run to a tolerance refines the bars: ``"shares"`` (default) those whose
        measured shares of a value's space error carry 80 % of it (:meth:`bar_shares` on each
        candidate's time companion), the a-priori grading a floor where a gradient's or a
        peak's error is over, and the a-priori rule itself where only theirs is; ``"bars"``
        those that need it most by the a-priori grading alone, each bar's own lowest
        frequency and mass (:mod:`flextop.discretization.indicator`); ``"uniform"`` every bar
        alike. Over the arm's 29 designs at rtol 1e-2 ``"shares"`` and ``"bars"`` are as
        honest (no ``ToleranceError``, the same worst under-estimate); ``"shares"`` costs
        56× the fixed run in the median against 68× on 26 % fewer unknowns, 3 % more in
        total (its markings' sweeps); the arm's tip-deflection optimization to rtol 1e-2
        took 1.65× less time (BENCHMARKS.md, "Refinement by measured shares",
        "Optimization to a tolerance").

    Raises
    ------
    SceneError
        If the scene cannot be built; the message names the entry.
    SettingsError
        If ``rtol`` is not in (0, 1), ``atol`` is negative, ``accuracy`` is not a preset's
        name, both ``accuracy`` and ``rtol`` are given, or ``refine`` is not ``"shares"``,
        ``"bars"`` or ``"uniform"``.
    """

    def __init__(self, scene: Scene | dict | str | os.PathLike, *, accuracy: str | None = None, rtol: float | None = None,
                 atol: float = 0.0, refine: str = "shares") -> None:
        spec = _as_spec(scene)
        try:
            self.spec = copy.deepcopy(spec)
        except RecursionError:
            raise SceneError("scene: nested too deeply to be a scene") from None
        self.accuracy = accuracy
        self.rtol, self.atol = rtol_of(accuracy, rtol, atol), atol
        if refine not in REFINE:
            raise SettingsError(f"refine must be one of {', '.join(map(repr, REFINE))}, got {refine!r}")
        self.refine = refine
        self._refined = Refined()
        self.model = _core.Model.from_dict(spec)
        raw = self.model.bars()
        self.bars = Bars(tuple(raw["name"]), np.asarray(raw["nodes"], dtype=int), np.asarray(raw["variable"], dtype=int),
                         np.asarray(raw["component"], dtype=int), np.asarray(raw["volume"]))
        self.joints = tuple(Joint(j["name"], j["kind"], tuple(j["nodes"]), range(*j["rows"]), j["driven"],
                                  None if j["drive_phases"] is None else tuple(j["drive_phases"]))
                            for j in self.model.joints())
        if self.analysis == "dynamic":  # a static structure may well be indeterminate
            _warn_if_over_constrained(self.mechanism)
        positions = np.asarray(self.model.reference_positions)
        plausibility.check(self.spec, float(np.linalg.norm(np.ptp(positions, axis=0))) if len(positions) else 0.0)

    @property
    def levels(self) -> Levels:
        """This simulation and its refined copies (:class:`~flextop.discretization.refinement.Levels`)."""
        return Levels(self, self._refined)

    def __reduce__(self) -> tuple[Any, tuple[dict, dict[str, Any]]]:
        """Pickled as its scene and options, and built again where it is unpickled (the
        engine's model and refined copies are not sent): a Simulation, and the problems
        that hold one, can be sent to another process or a cluster."""
        return rebuilt, (self.spec, self.options)

    def bar_densities(self, x: DesignLike = None) -> np.ndarray:
        """The density of every bar for design ``x`` (``None``: full density), checked as
        :meth:`run` checks it (:meth:`checked_design`); bars that are not designed
        (variable −1) are at 1."""
        xv = None if x is None else self.checked_design(x)
        variable = np.asarray(self.bars.variable, dtype=int)
        if xv is None:
            return np.ones(variable.size)
        return np.where(variable >= 0, xv[np.maximum(variable, 0)] if xv.size else 1.0, 1.0)

    def cell_densities(self, x: DesignLike = None) -> np.ndarray:
        """The density of every cell of the continuum members for design ``x`` (``None``:
        full density), checked as :meth:`run` checks it; cells that are not designed are at
        1."""
        xv = None if x is None else self.checked_design(x)
        variable = np.asarray(self.model.cells()["variable"], dtype=int)
        if xv is None:
            return np.ones(variable.size)
        return np.where(variable >= 0, xv[np.maximum(variable, 0)] if xv.size else 1.0, 1.0)

    @cached_property
    def mechanism(self) -> dict[str, Any]:
        """The rigid mechanism behind the flexible one: ``frames`` (rigid clusters),
        ``mobility`` (rigid-body modes the joints leave free), ``redundant_rows`` (rows of
        the joints that depend on others), ``repeated_rows`` (how many of those only repeat
        what undriven joints between the same two frames, or a frame and the ground,
        already impose: a frame pinned at both ends, a ring hinged at every node of an edge;
        they agree in every motion) and the ``over_constraining`` joints' names, those whose
        rows enter the other dependencies (empty when there are none)."""
        return dict(self.model.mechanism())

    @property
    def options(self) -> dict[str, Any]:
        """The keyword arguments that rebuild this Simulation from its scene: ``accuracy``,
        or ``rtol``, ``atol`` and ``refine``."""
        return {"accuracy": self.accuracy, "rtol": None if self.accuracy else self.rtol, "atol": self.atol, "refine": self.refine}

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
        """Index of the node called ``name``; a :class:`SettingsError` naming it if there is none."""
        try:
            return self.model.node_names.index(name)
        except ValueError:
            near = difflib.get_close_matches(str(name), self.model.node_names, n=3)
            hint = f" (did you mean {', '.join(map(repr, near))}?)" if near else ""
            raise SettingsError(f"node {name!r}: the scene has no node of that name{hint}") from None

    # -- runs ---------------------------------------------------------------------------

    def run(self, x: DesignLike = None, *, rtol: float | None = None, atol: float | None = None, responses: Sequence[str] | str | None = None,
            local_tol: float | None = None, t_end: float | None = None, h: float | None = None, rho_inf: float | None = None,
            tol: float | None = None, max_iter: int | None = None, newton: str | None = None, mass: str | None = None,
            load_steps: int | None = None, analysis: str | None = None,
            progress: Callable[[float], object] | None = None) -> Results | StaticResults:
        """Runs the scene for design ``x`` (``None``: every bar at full density).

        Dynamic scenes integrate to ``t_end`` with step ``h`` — at most ``t_end``, and
        shortened, if needed, so that a whole number of steps ends exactly at ``t_end``;
        ``results.raw["h"]`` is the step used — and spectral radius ``rho_inf`` (defaults from the scene's ``[simulation]``
        table, ``rho_inf`` 0.8);
        ``tol`` is the relative Newton tolerance (1e-10), ``max_iter`` the iterations per
        step (20), ``newton`` ``"full"`` (a new iteration matrix every iteration, but at the
        one where the step before ended, whose held factors' correction ends the step at
        round-off) or
        ``"modified"`` (the step's first kept while the residual falls tenfold per
        iteration: the same solution to ``tol``, 12–26 % faster on the arm's designs
        measured, BENCHMARKS.md; 5–12 % on three of them since full Newton ends a step on
        its held factors, a scratch timing of a run), ``mass`` ``"consistent"`` (linear interpolation),
        ``"lumped"`` or ``"bar_lumped"`` (a bar's mass lumped on its nodes and its end
        nodes coupled so that its rigid motion carries its exact inertia: consistent on a
        bar of one element, and on a split bar its own bending modes converge at fourth
        order in its elements rather than the second; BENCHMARKS.md "Mass of a split
        bar"). Static scenes solve the
        equilibrium with ``load_steps`` initial load increments; ``analysis="linear"`` solves
        the small-displacement problem ``K₀ u = f`` instead (the tangent at the reference,
        the joints linear about it, the load at once: the 88-line code's analysis, exact
        gradients too), ``"nonlinear"`` (the default) the geometrically nonlinear one.

        With a tolerance (``rtol`` here or on the :class:`Simulation`) and no ``h``, the
        elements per bar and the step are chosen so that the estimated error of
        ``responses`` (default: ``tip_deflection`` if the scene has a tip, else
        ``compliance``) is at most ``rtol·|f| + atol``; the results then come from the
        refined scene and tell their ``discretization``.

        With ``local_tol`` instead, the steps vary: local error control of generalized-α
        (the position error of each step against ``local_tol`` times the model's size, and
        ``local_tol`` rad), starting from ``h``, ending exactly at every kink of the motion
        laws and at ``t_end``; ``results.steps`` holds them. A step where Newton fails or whose
        solution turns a cell inside out (or collapses a spring) is cut to a quarter, down to
        the smallest step, where that failure's error ends the run. On the reference scenes it
        needs as many steps as uniform steps for the same error of d, or more (x = 0.4 arm;
        BENCHMARKS.md); it is meant for motions whose difficulty varies in time.

        ``progress`` (a dynamic run on one discretization: fixed steps or ``local_tol``) is
        called with the time reached (s) about every 50 ms, for a progress bar.

        Raises ``DesignError``, ``SettingsError``, ``SimulationError`` (with the time,
        residual and iteration count of a failed Newton step) or ``ToleranceError``.
        """
        xv = self._design(x)
        given = {"t_end": t_end, "tol": tol, "max_iter": max_iter, "newton": newton, "analysis": analysis}
        given |= {"load_steps": load_steps} if self.analysis == "static" else {"h": h, "rho_inf": rho_inf, "mass": mass}
        settings = self._settings(**given)
        if local_tol is not None:
            if rtol is not None or self.analysis == "static":
                raise SettingsError("local_tol applies to a dynamic run without rtol")
            return self.run_fixed(xv, settings, local_tol=local_tol, progress=progress)
        wanted = self._tolerance(rtol, atol, h)
        if wanted is None:
            return self.run_fixed(xv, settings, progress=progress)
        if progress is not None:
            raise SettingsError("progress reports a run on one discretization; a run to a tolerance makes several")
        names = [responses] if isinstance(responses, str) else list(responses or [self._default_response()])
        return refinement.to_tolerance(self, xv, names, wanted, settings, None)

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

    def run_fixed(self, xv: np.ndarray | None, settings: dict[str, Any], *, local_tol: float | None = None,
                  steps: np.ndarray | None = None, guide: np.ndarray | None = None,
                  progress: Callable[[float], object] | None = None) -> Results | StaticResults:
        """One run on the scene as it is: uniform steps, the given ``steps``, or steps chosen
        to ``local_tol``; Newton starts each step from ``guide`` (a nearby run's ``q`` at
        the same times) when given. ``xv`` is a checked design vector and ``settings`` the
        run settings as the engine takes them: the primitive that :meth:`run` and the
        refinement of :mod:`flextop.discretization` compose."""
        if self.analysis == "static":
            static = StaticResults(self, _core.solve_static(self.model, xv, settings), xv, settings)
            _warn_if_implausible_static(static)
            return static
        if local_tol is not None and (isinstance(local_tol, bool) or not isinstance(local_tol, (int, float, np.number))):
            raise SettingsError(f"local_tol must be a number, got {local_tol!r}")
        raw = _core.simulate(self.model, xv, settings, local_tol, None if steps is None else [float(h) for h in steps], guide,
                             progress)
        res = Results(self, raw, xv, settings)
        _warn_if_energy_created(res)
        _warn_if_drives_cut_off(self.joints, float(res.time[-1]))
        if steps is None and local_tol is None:
            _warn_if_step_shortened(settings.get("h") or self.spec.get("simulation", {}).get("h"), raw["h"])
        return res

    def _settings(self, **given: Any) -> dict[str, Any]:
        """The run settings given explicitly."""
        return {k: v for k, v in given.items() if v is not None}

    def run_with_sensitivities(self, x: DesignLike, responses: Sequence[str] | str = ("tip_deflection",), *,
                               method: str = "auto", memory: str = "auto", rtol: float | None = None, atol: float | None = None,
                               start: Discretization | None = None, hold_gradients: bool = True, extrapolate: bool = True,
                               local_tol: float | None = None, parameters: Sequence[str] = (), made: Sequence[Results] = (),
                               time_estimate: str = "adjoint", **settings: Any) -> Sensitivities:
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
        derivatives of those values on the grid accepted, their error not estimated. With
        ``extrapolate`` (the default), a candidate is also judged on Richardson's
        extrapolation in the step, ``(4 f(h) − f(2h))/3`` with the same combination of the
        gradients (each the exact derivative of its value), its error estimated from the
        runs at 4h and 8h; where that estimate is the smaller, the extrapolated values are
        returned and ``discretization.extrapolated`` says so (the peaks extrapolated alike).
        ``time_estimate``: ``"adjoint"`` (the default; gradients held and made by the adjoint
        method) judges a candidate on the time errors its own adjoint sweep estimates wherever
        they agree with its half-steps run (``tolerance.agreed_time``: no runs at 4h and 8h);
        ``"doubling"``, on step doubling alone.
        The peaks of peak-limited responses (a drive's torque, a stress) are held to
        ``rtol`` too, their estimated errors in ``peak_errors``. ``made``: runs of ``x`` on
        this scene's refined copies already made (an optimization's trial on the grid
        held): with ``hold_gradients=False``, a candidate or companion on one of their grids
        and steps reads it instead of running again (a run of another design is a
        :class:`SettingsError`). With ``local_tol`` (as in :meth:`run`) the steps are chosen by local
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
            steps = self.run_fixed(xv, self._settings(**settings), local_tol=local_tol).steps
            return self.sensitivities_fixed(xv, names, self._settings(**gradients, **settings), steps)
        wanted = self._tolerance(rtol, atol, settings.get("h"))
        if wanted is None:
            return self.sensitivities_fixed(xv, names, self._settings(**gradients, **settings))
        if time_estimate not in tolerance.TIME_ESTIMATES:
            raise SettingsError(f"time_estimate must be one of {', '.join(map(repr, tolerance.TIME_ESTIMATES))}, "
                                f"got {time_estimate!r}")
        return refinement.to_tolerance(self, xv, names, wanted, self._settings(**settings), gradients, start, hold_gradients,
                                       extrapolate, made, adjoint=time_estimate == "adjoint")

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

    def sensitivities_fixed(self, xv: np.ndarray, names: list[str], settings: dict[str, Any], steps: np.ndarray | None = None,
                            about: Results | None = None) -> Sensitivities:
        """Responses ``names`` and their exact gradients on the scene as it is (its steps, or
        the given ``steps``), ``settings`` as the engine takes them (with ``method``,
        ``memory`` and ``parameters``): the primitive of :meth:`run_with_sensitivities`.
        With ``about``, this scene's :meth:`run_fixed` of ``xv`` with these settings and
        steps, by the adjoint method about its states: the run is not made again (a
        ``SettingsError`` if it ran another design or other settings)."""
        grid = None if steps is None else [float(h) for h in steps]
        settings = dict(settings)
        parameters = settings.pop("parameters", [])
        path = None if about is None else self._states_of(about, xv, settings)
        out = _core.run_with_sensitivities(self.model, xv, names, settings, grid, parameters, path)
        timings = {"simulation": out["simulation_seconds"], "gradients": out["gradient_seconds"]}
        peaks = {n: p for n, p in zip(names, out["peaks"]) if p is not None}
        return Sensitivities(tuple(names), out["values"], out["gradients"], out["method"], timings, steps=steps, peaks=peaks,
                             parameters=tuple(parameters), parameter_gradients=out["parameter_gradients"],
                             time_errors=out["time_errors"])

    def _states_of(self, run: Results, xv: np.ndarray | None, settings: dict[str, Any]) -> tuple[np.ndarray, ...]:
        """The states of ``run``, checked to be this scene's run of ``xv`` with ``settings``
        (``method`` and ``memory`` aside)."""
        same = {k: v for k, v in settings.items() if k not in ("method", "memory")}
        design = (run.x is None) == (xv is None) and (xv is None or np.array_equal(run.x, xv))
        if not isinstance(run, Results) or run.simulation is not self or not design or run.settings != same:
            raise SettingsError("about must be this scene's run of the same design with the same settings: "
                                "its gradients are those of the run it holds")
        return run.q, run.qdot, run.qddot, run.lam

    # -- runs to a tolerance ------------------------------------------------------------

    def _tolerance(self, rtol: float | None, atol: float | None, h: float | None) -> tuple[float, float] | None:
        """The tolerance a run is made to, or ``None`` for a fixed-step run (:func:`~flextop.discretization.accuracy.run_tolerance`)."""
        return run_tolerance((self.rtol, self.atol), rtol, atol, h)

    def _default_response(self) -> str:
        return "tip_deflection" if self.tip is not None and self.analysis == "dynamic" else "compliance"

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
        built = Simulation(spec, rtol=self.rtol, atol=self.atol, refine=self.refine)
        index = {name: k for k, name in enumerate(self.variable_names)}
        return built, np.array([xv[index[name]] for name in built.variable_names])

    def _designs(self, designs: Iterable[DesignLike]) -> list[np.ndarray | None]:
        """Each of ``designs`` as :meth:`_design` makes it; a bad one is named by its index."""
        return design_vectors(designs, self.n_design)

    def checked_design(self, x: DesignLike) -> np.ndarray:
        """``x`` as a run reads it: one number for every variable or a vector of
        :attr:`n_design` real numbers, each finite and in ``[x_min, 1]``; else the
        :class:`DesignError` that :meth:`run` raises, naming the variable."""
        xv = self._design(x)
        if xv is None:
            raise DesignError(f"a design is needed: one number or a vector of {self.n_design}")
        self.model.check_design(xv)
        return xv

    def _design(self, x: Any) -> np.ndarray | None:
        return design_vector(x, self.n_design)

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
        return modal.natural_modes(self.levels.model, n, self._design(x), rtol, self._settings(mass=mass))

    def bar_shares(self, x: DesignLike, responses: Sequence[str] | str = ("tip_deflection",), *, h: float | None = None,
                   t_end: float | None = None, rho_inf: float | None = None, mass: str | None = None) -> indicator.Shares:
        """Each bar's share of the change of ``responses`` when the elements of every frame
        bar are split in two, for design ``x``: where refinement pays, measured (the
        a-posteriori indicator of :mod:`flextop.discretization.indicator`). One run of the
        split scene and two adjoint sweeps of this one, on uniform steps ``h`` (the scene's by
        default; other settings as in :meth:`run`). ``shares.shares[name]`` follows
        ``self.bars.name``; ``shares.change`` is the change measured, ``unattributed`` what
        the shares leave of it."""
        xv = self._design(x)
        settings = self._settings(h=h, t_end=t_end, rho_inf=rho_inf, mass=mass)
        names = [responses] if isinstance(responses, str) else list(responses)
        if self.analysis != "dynamic":
            raise SettingsError("bar shares are measured on a dynamic run; a static scene's refinement is uniform")
        design = np.ones(self.n_design) if xv is None else xv
        return indicator.shares(self, design, names, settings, self._uniform_steps(settings))

    def _uniform_steps(self, settings: dict[str, Any], count: int | None = None) -> np.ndarray:
        """``count`` uniform steps over the run (as many as the step ``h`` of ``settings``, or
        else of the scene, makes; a sixteenth of the run without one)."""
        duration = refinement.t_end(self, settings)
        if count is None:
            step = settings.get("h") or self.spec.get("simulation", {}).get("h") or duration / 16
            count = max(1, math.ceil(duration / step - 1e-9))
        elif isinstance(count, bool) or not (isinstance(count, (int, np.integer)) and count >= 1):
            raise SettingsError(f"steps must be a positive whole number, got {count!r}")
        limit = dict(_core.size_limits())["steps"]
        if count > limit:
            raise SettingsError(f"steps: {count} steps; at most {limit:.0e} are allowed")
        return np.full(int(count), duration / count)

    def time_errors(self, x: DesignLike, responses: Sequence[str] | str = ("tip_deflection",), *, steps: int | None = None,
                    t_end: float | None = None, rho_inf: float | None = None, mass: str | None = None) -> dict[str, tuple[float, float]]:
        """Each response's value for design ``x`` on ``steps`` uniform steps (the scene's step
        by default; other settings as in :meth:`run`) and its time error ``f(h) − f`` to
        leading order in the step, estimated from that run alone: the steps' local errors
        (generalized-α's truncation, from the accelerations' differences) weighted by the
        run's adjoint, one backward sweep. The space error is not in it."""
        xv = self._design(x)
        settings = self._settings(t_end=t_end, rho_inf=rho_inf, mass=mass)
        names = [responses] if isinstance(responses, str) else list(responses)
        if self.analysis != "dynamic":
            raise SettingsError("a time error is a motion's; this scene is static")
        design = np.ones(self.n_design) if xv is None else xv
        grid = [float(h) for h in self._uniform_steps(settings, steps)]
        out = _core.time_errors(self.model, design, names, settings, grid)
        return {name: (float(out["values"][k]), float(out["errors"][k])) for k, name in enumerate(names)}

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

_simulations: OrderedDict[str, Any] = OrderedDict()
_simulations_lock = threading.Lock()


@dataclass(frozen=True)
class Task:
    """One run in plain data, for :func:`perform` in any process: ``responses`` of
    ``scene`` (a scene dict) at design ``x``, with gradients (``options`` of
    :meth:`Simulation.run_with_sensitivities`) or without (``options`` of
    :meth:`Simulation.run`); ``simulation`` holds the simulation's own options (a
    :class:`Simulation`'s or a :class:`~flextop.spatial.SpatialSimulation`'s ``options``)."""

    scene: dict
    x: np.ndarray | None
    responses: tuple[str, ...]
    gradients: bool = True
    options: dict[str, Any] = field(default_factory=dict)
    simulation: dict[str, Any] = field(default_factory=dict)
    held: tuple[Discretization, np.ndarray | None] | None = None
    """A discretization held and the design its bars were graded for: the run is made on
    that grid (:func:`~flextop.discretization.refinement.on_grid`, ``options`` its
    settings), an optimization's between its measurements. A spatial scene grades its beams
    at the design it runs (as :class:`~flextop.problems.SpatialProblem` does), not at the
    one given here."""


def perform(task: Task) -> Sensitivities:
    """Runs ``task`` on this process's :class:`Simulation` of its scene, built on first use."""
    sim = cached(task.scene, task.simulation)
    if task.held is not None:
        return refinement.on_grid(sim, task.x, task.responses, *task.held, task.options)
    if task.gradients:
        return sim.run_with_sensitivities(task.x, task.responses, **task.options)
    res = sim.run(task.x, responses=task.responses, **task.options)
    values = np.array([res.response(name) for name in task.responses])
    return Sensitivities(task.responses, values, None, "none", {}, res.discretization, dict(res.errors))


def rebuilt(scene: dict, options: dict[str, Any]) -> Simulation:
    """The :class:`Simulation` of ``scene`` with ``options``: what an unpickled one is."""
    return Simulation(scene, **options)


def _key(scene: dict, options: dict[str, Any]) -> str:
    return json.dumps([scene, options], sort_keys=True, default=float)


def cached(scene: dict, options: dict[str, Any], sim: Any = None, make: Callable[..., Any] = Simulation) -> Any:
    """This process's simulation of ``scene`` and ``options`` (``sim`` itself if given, else
    ``make(scene, **options)``: a :class:`Simulation`, or a spatial scene's
    :class:`~flextop.spatial.SpatialSimulation`), kept for the next task; safe from several
    threads."""
    key = _key(scene, options)
    with _simulations_lock:
        if sim is not None:
            _simulations[key] = sim
        found = _simulations.get(key)
    if found is None:
        found = make(scene, **options)
    with _simulations_lock:
        found = _simulations.setdefault(key, found)
        _simulations.move_to_end(key)
        while len(_simulations) > CACHED_SCENES:
            _simulations.popitem(last=False)
    return found


def remember(sim: Any) -> None:
    """Lets this process's tasks on ``sim``'s scene and options run on ``sim`` itself (a
    :class:`Simulation` or a :class:`~flextop.spatial.SpatialSimulation`)."""
    cached(sim.spec, sim.options, sim)


def load(path: str | os.PathLike) -> Results | StaticResults | Sensitivities:
    """The results saved at ``path`` by ``results.save(path)``, on the Simulation of their
    saved scene and options; or the :class:`Sensitivities` saved by their ``save``."""
    meta, raw, x = saved.read(path)
    d = meta["discretization"]
    if meta["kind"] == "sensitivities":
        return Sensitivities(tuple(meta["names"]), raw["values"], raw.get("gradients"), meta["method"], meta["timings"],
                             None if d is None else Discretization(*d), meta["errors"], meta["gradient_errors"],
                             raw.get("steps"), meta["peaks"], tuple(meta["parameters"]), raw.get("parameter_gradients"),
                             meta.get("peak_errors", {}), raw.get("time_errors"))
    sim = Simulation(meta["scene"], **meta["simulation"])
    kind = Results if meta["kind"] == "dynamic" else StaticResults
    return kind(sim, raw, x, meta["settings"], None if d is None else Discretization(*d), meta["errors"])
