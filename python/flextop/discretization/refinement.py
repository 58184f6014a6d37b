"""Where a run's discretization comes from: the scene's own, copies of the scene with bars
refined (levels: every bar alike, or graded bar by bar by :mod:`.indicator`) and members'
cells split (:mod:`.members`, every member alike), the companion
runs of step doubling, and the loop that refines until the estimate of :mod:`.tolerance`
meets the tolerance asked for.

A :class:`~flextop.simulation.Simulation` runs one discretization at a time
(``run_fixed``, ``sensitivities_fixed``); this module composes those runs. Results made to a
tolerance carry their companions, and any other run gets them here on its first error
estimate.
"""

from __future__ import annotations

import math
from time import perf_counter
from collections import OrderedDict
from dataclasses import replace
from functools import cached_property
from collections.abc import Sequence
from typing import Any, Protocol

import numpy as np

from .. import _core
from ..errors import SettingsError, SimulationError
from ..execution import side_by_side
from ..responses import PEAK_LIMITED
from . import indicator, tolerance
from .accuracy import split_by
from .members import split_members
from .tolerance import Discretization

class Simulation(Protocol):
    """What the refinement reads of a :class:`flextop.Simulation`: its scene, its kind, its
    engine model, its refined copies and its runs on one discretization (which return
    results, or sensitivities, that carry their ``discretization``, ``errors`` and
    ``companions``)."""

    spec: dict
    model: Any
    levels: Levels
    refine: str

    @property
    def analysis(self) -> str: ...

    @property
    def n_design(self) -> int: ...

    def run_fixed(self, xv: np.ndarray | None, settings: dict[str, Any], *, local_tol: float | None = None,
                  steps: np.ndarray | None = None, guide: np.ndarray | None = None) -> Any: ...

    def sensitivities_fixed(self, xv: np.ndarray | None, names: list[str], settings: dict[str, Any],
                            steps: np.ndarray | None = None, about: Any = None) -> Any: ...

    def run_with_sensitivities(self, x: Any, responses: Sequence[str] | str, **options: Any) -> Any: ...


_Run = Any
"""A run's results (:class:`flextop.Results` or :class:`flextop.StaticResults`)."""


GRADED_KEPT = 8
"""Graded copies of a scene each :class:`Levels` keeps (the most recently used): an
optimization's designs grade the bars differently as they change."""


class Refined:
    """The refined copies of a simulation, each built once, on first use: with ``r`` times
    the elements of every bar, and the graded ones most recently used. The simulation keeps
    them; they do not refer back to it, so that a simulation let go is freed at once (a
    large scene's millions of objects are not left to the cyclic garbage collector, whose
    pass delays Ctrl-C)."""

    def __init__(self) -> None:
        self.uniform: dict[int, Simulation] = {}
        self.graded: OrderedDict[tuple[int, ...], Simulation] = OrderedDict()


class Levels:
    """A simulation and its scene refined: with ``r`` times the elements of every bar
    (``levels[r]``), or of each bar its own factor (:meth:`graded`), with the same design
    variables, kept in the simulation's :class:`Refined`."""

    def __init__(self, base: Simulation, refined: Refined) -> None:
        self.base, self._refined = base, refined

    def __getitem__(self, refinement: int) -> Simulation:
        if refinement == 1:
            return self.base
        made = self._refined.uniform
        if refinement not in made:
            simulation: Any = type(self.base)  # the base's class: a refined copy is built like it
            made[refinement] = simulation(split_by(self.base.spec, refinement))
        return made[refinement]

    def model(self, refinement: int) -> _core.Model:
        """The engine model at ``refinement``."""
        return self[refinement].model

    def graded(self, factors: np.ndarray, cells: int = 1) -> Simulation:
        """The scene with each bar's elements times its entry of ``factors`` and every
        continuum member's cells ``cells × cells`` times
        (:func:`~flextop.discretization.members.split_members`)."""
        members = self.cell_count > 0
        uniform = cells if members or len(factors) == 0 else int(factors[0])
        if np.all(factors == uniform):
            return self[uniform]
        key = (cells if members else 1, *(int(f) for f in factors))
        made = self._refined.graded
        if key not in made:
            simulation: Any = type(self.base)
            spec = indicator.refined_spec(self.base.spec, self.base.model.bars(), factors)
            split_members(spec, cells)
            made[key] = simulation(spec)
            while len(made) > GRADED_KEPT:
                made.popitem(last=False)
        made.move_to_end(key)
        return made[key]

    def factors(self, d: Discretization, x: np.ndarray | None) -> np.ndarray:
        """Each bar's factor on its elements in the scene refined as ``d`` says for the
        design ``x``: graded by :mod:`.indicator` (a dynamic scene refined by bars) and at
        least ``d.floor``, or ``d.refinement`` on every bar; times ``d.uniform``."""
        base = self.base
        if d.factors:
            return d.uniform * np.asarray(d.factors, dtype=np.int64)
        graded = base.refine in ("bars", "shares") and base.analysis == "dynamic"
        return d.uniform * np.maximum(d.floor, indicator.bar_factors(base.model, x, d.refinement, graded))

    def at(self, d: Discretization, x: np.ndarray | None) -> Simulation:
        """The scene refined as ``d`` says for the design ``x``."""
        return self.graded(self.factors(d, x), self.cells(d))

    @staticmethod
    def cells(d: Discretization) -> int:
        """The factor on the elements along each side of every member's cell as ``d`` says:
        its ``refinement`` (members are graded by no indicator), times ``d.uniform``."""
        return d.uniform * d.refinement

    def elements(self, d: Discretization, x: np.ndarray | None) -> float:
        """The elements of the scene refined as ``d`` says, over the scene's (bars'
        elements and members' cells alike)."""
        elements = self.base.model.bars()["elements"]
        refined = np.dot(elements, self.factors(d, x)) + self.cell_count * self.cells(d) ** 2
        return float(refined / max(1, sum(elements) + self.cell_count))

    @cached_property
    def cell_count(self) -> int:
        """The scene's elements in continuum members."""
        return len(self.base.model.cells()["variable"]) if self.base.spec.get("members") else 0


def t_end(simulation: Simulation, settings: dict[str, Any]) -> float:
    """The duration of a dynamic run: the run's ``t_end``, or the scene's."""
    value = settings.get("t_end") or simulation.spec.get("simulation", {}).get("t_end")
    if value is None:
        raise SettingsError("t_end: give it in the scene's [simulation] table or to the run")
    if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
        raise SettingsError(f"t_end: must be a positive number of seconds, got {value!r}")
    return float(value)


def first(simulation: Simulation, settings: dict[str, Any]) -> Discretization:
    """The scene's own discretization: its elements per bar (or member cell) and step (16
    steps if the scene gives none)."""
    members, bars = bool(simulation.spec.get("members")), len(simulation.model.bars()["elements"]) > 0
    unit = "bar and member cell" if members and bars else "member cell" if members else "bar"
    if simulation.analysis == "static":
        return Discretization(1, 0, unit=unit)
    duration = t_end(simulation, settings)
    h = simulation.spec.get("simulation", {}).get("h") or duration / 16
    if not (isinstance(h, (int, float)) and math.isfinite(h) and 0 < h <= duration):
        raise SettingsError(f"simulation.h: must be a step in (0, t_end], got {h!r}")
    return replace(tolerance.start(math.ceil(duration / h - 1e-9)), unit=unit)


def companion(fine: Simulation, xv: np.ndarray | None, settings: dict[str, Any], plain: dict[str, Any],
              coarse: _Run | None, steps: np.ndarray | None = None) -> _Run:
    """A companion run of step doubling on ``fine`` with ``settings``, each step's Newton
    started from the states of ``coarse`` (a run with half the elements of every bar on the
    same steps) carried over, each element's middle node on its cubic shape. Where that
    fails, the run with ``plain`` settings and no guide decides: a guide or a kept matrix
    that led Newton astray must not pass for a model that cannot run."""
    guide = None if coarse is None else _core.prolong(coarse.simulation.model, fine.model, coarse.q)
    try:
        return fine.run_fixed(xv, settings, steps=steps, guide=guide)
    except SimulationError:
        if guide is None and plain == settings:
            raise
        return fine.run_fixed(xv, plain, steps=steps)


def merged(steps: np.ndarray, k: int) -> np.ndarray:
    """The steps summed in consecutive groups of ``k`` (the last group may be shorter)."""
    return np.add.reduceat(steps, np.arange(0, len(steps), k))


def companions_of(run: _Run) -> tuple[_Run | None, _Run | None, _Run]:
    """The runs an error estimate of ``run`` compares with, made on first use: its steps
    merged in pairs and in fours, and twice the elements per bar on the steps merged in
    pairs (a static scene: twice the elements per bar only), a continuum member's cells
    split in two along each side."""
    if run.companions is None:
        steps, half, quarter = None, None, None
        simulation = run.simulation
        if simulation.analysis == "dynamic":
            steps = run.raw["steps"][1:]  # the step sizes that ran (Results.steps)
            if len(steps) < 4:
                raise SettingsError("an error estimate needs a run of at least 4 steps")
            half, quarter = (_companion_run(f"its steps merged {'in pairs' if k == 2 else 'in fours'}",
                                            lambda k=k: simulation.run_fixed(run.x, run.settings, steps=merged(steps, k)))
                             for k in (2, 4))
        split_steps = None if steps is None else merged(steps, 2)
        split = _companion_run("twice the elements per bar", lambda: companion(simulation.levels[2], run.x, run.settings,
                                                                                run.settings, half, split_steps))
        run.companions = (half, quarter, split)
    return run.companions


def _companion_run(what: str, make: Any) -> Any:
    """A companion run of an error estimate, whose failure is named as the companion's: the
    run being judged succeeded, a coarser run beside it did not."""
    try:
        return make()
    except SimulationError as error:
        raise SimulationError(f"the error cannot be estimated: the run succeeded, but its companion on {what} failed "
                              f"({error}); a run to a tolerance (rtol=...) estimates it from finer runs") from None


def extrapolated(fine: Any, half: Any) -> Any:
    """Sensitivities at h and 2h on one grid combined by Richardson's extrapolation
    (:func:`tolerance.richardson`): values, design and parameter gradients, each gradient
    the exact derivative of its extrapolated value, and peaks. The timings add up."""
    def combined(field: str) -> np.ndarray | None:
        at_h, at_2h = getattr(fine, field), getattr(half, field)
        return None if at_h is None else tolerance.richardson([at_h], [at_2h])[0]

    timings = {key: fine.timings.get(key, 0.0) + half.timings.get(key, 0.0) for key in {*fine.timings, *half.timings}}
    peaks = {name: float(tolerance.richardson([np.array(p)], [np.array(half.peaks[name])])[0]) for name, p in fine.peaks.items()}
    return replace(fine, values=combined("values"), gradients=combined("gradients"),
                   parameter_gradients=combined("parameter_gradients"), timings=timings, steps=None, peaks=peaks,
                   time_errors=None)


HELD_NEWTON_TOL = 1e-8
"""Newton's relative tolerance on the grid held (:func:`on_grid`, :class:`Held`), unless the
settings give one: on 30 arm designs (the 22 of ``benches/tolerance.py``, uniform 0.08 and
0.12, MMA's iterates 5, 10 and 20 of both objectives) at 1×, 4× and 8× the elements per bar
and 1088 or 544 steps, against the default 1e-10, d moved by at most 1.1e-8 and ∇d by 4.4e-8
(relative), far below any tolerance a grid is held to, and Newton took 1.0–3.0 iterations
per step where it took 1.1–4.2."""


def _held(simulation: Simulation, d: Discretization, graded_for: np.ndarray | None,
          settings: dict[str, Any]) -> tuple[Simulation, list[dict[str, Any]]]:
    """The grid held (each bar's elements as graded for the design ``graded_for``) and the
    settings of its runs: its steps, then twice them where ``d`` is extrapolated. Newton is
    modified (the same values to its tolerance, in a quarter less time on the arm's held
    grid) at :data:`HELD_NEWTON_TOL`, unless ``settings`` say otherwise."""
    settings = {"newton": "modified", "tol": HELD_NEWTON_TOL, **settings}
    if d.steps:
        settings["h"] = t_end(simulation, settings) / d.steps
    runs = [settings, {**settings, "h": 2 * settings["h"]}] if d.extrapolated else [settings]
    return simulation.levels.at(d, graded_for), runs


def on_grid(simulation: Simulation, xv: np.ndarray, names: Sequence[str], d: Discretization, graded_for: np.ndarray | None,
            settings: dict[str, Any]) -> Any:
    """Sensitivities on the discretization ``d`` held (an optimization's between its
    measurements): its steps and each bar's elements as graded for the design
    ``graded_for`` (where its error was measured), extrapolated from half the steps where
    ``d`` is, the two runs side by side (:func:`~flextop.execution.side_by_side`), each as
    :func:`_held` sets it."""
    grid, runs = _held(simulation, d, graded_for, settings)
    made = [lambda s=s: grid.run_with_sensitivities(xv, names, **s) for s in runs]
    return extrapolated(*side_by_side(*made)) if d.extrapolated else made[0]()


class Held:
    """An evaluation in two phases: the runs of ``grid`` with each of ``runs`` (run settings;
    two, at h and 2h, are made side by side and extrapolated) and their ``values`` and
    ``peaks`` read, then the gradients only when asked (:meth:`sensitivities`), by the
    adjoint method about the same runs, which are not made again. An optimizer that rejects
    the design (MMA's inner iterations, which read the values only) does not pay for them: on
    the arm's held grid the adjoint is two fifths of a run with gradients. ``method="direct"``
    makes the runs again, with the gradients. :meth:`on` makes it on a discretization held,
    as :func:`on_grid` does."""

    @classmethod
    def on(cls, simulation: Simulation, xv: np.ndarray, names: Sequence[str], d: Discretization,
           graded_for: np.ndarray | None, settings: dict[str, Any]) -> Held:
        """On the discretization ``d`` held, graded for ``graded_for`` (:func:`_held`);
        ``settings`` may hold ``method`` and ``memory``."""
        plain = {k: v for k, v in settings.items() if k not in ("method", "memory")}
        grid, runs = _held(simulation, d, graded_for, plain)
        return cls(grid, xv, names, runs, settings.get("method", "auto"))

    def __init__(self, grid: Simulation, xv: np.ndarray, names: Sequence[str], runs: list[dict[str, Any]],
                 method: str = "auto") -> None:
        self.grid, self.settings, self.method = grid, runs, method
        self.xv, self.names = xv, list(names)
        clock = perf_counter()

        def read(settings: dict[str, Any]) -> tuple[Any, tuple[np.ndarray, list[float | None]]]:
            run = self.grid.run_fixed(xv, settings)
            return run, run.values_and_peaks(self.names)

        made = [lambda s=s: read(s) for s in self.settings]
        both = list(side_by_side(*made)) if len(made) == 2 else [made[0]()]
        self.seconds = perf_counter() - clock
        self.runs = [run for run, _ in both]
        readings = [values_and_peaks for _, values_and_peaks in both]
        self.values = combined([values for values, _ in readings])
        self.peaks = {n: float(combined([np.array([peaks[k]]) for _, peaks in readings])[0])
                      for k, n in enumerate(self.names) if readings[0][1][k] is not None}

    def sensitivities(self) -> Any:
        """The gradients of :attr:`values`: each run's by the adjoint method about its states
        (made again with them for ``method="direct"``), extrapolated as the values are."""
        def differentiated(run: Any, settings: dict[str, Any]) -> Any:
            about = None if self.method == "direct" else run
            return self.grid.sensitivities_fixed(self.xv, self.names, {**settings, "method": self.method}, about=about)

        made = [lambda r=r, s=s: differentiated(r, s) for r, s in zip(self.runs, self.settings)]
        out = extrapolated(*side_by_side(*made)) if len(made) == 2 else made[0]()
        return replace(out, timings={"simulation": self.seconds, "gradients": sum(out.timings.values())})


def combined(runs: list[np.ndarray]) -> np.ndarray:
    """One run's quantities, or those of the runs at h and 2h extrapolated
    (:func:`tolerance.richardson`)."""
    return runs[0] if len(runs) == 1 else tolerance.richardson([runs[0]], [runs[1]])[0]


def marks(simulation: Simulation, d: Discretization, missed: bool, ratios: np.ndarray, xv: np.ndarray | None,
          names: Sequence[str], settings: dict[str, Any], split: _Run | None = None) -> Discretization | None:
    """The refinement after candidate ``d`` (``refine="shares"``), given each quantity's space
    error over its budget (``ratios``: the responses' values first). Where a value's is over
    half of it, the bars whose shares of the change of splitting every bar carry 80 % of it
    (:func:`indicator.shares` on ``d``'s time companion and its split run, ``split`` where
    the candidate's space companion made it, relative to each response and summed over
    them; :func:`tolerance.dorfler`) double their elements, once or
    twice as the error asks (:func:`tolerance.doublings`). The shares are the values': where a
    gradient's or a peak's is over, the a-priori grading's refinement doubles too, and no bar
    has fewer elements than it gives. Where the last marking ``missed`` (the space error did
    not fall), every bar doubles. ``None`` for a scene with no frame bar, and where no
    value's error has marked a bar yet nor is over now: a gradient's or a peak's error alone
    follows the a-priori grading, whose floor rises where it stalls (the void bars of a
    chords-only arm, whose own gradients the chords' refinement does not touch)."""
    if "frame" not in simulation.model.bars()["kind"] or (not d.factors and ratios[:len(names)].max() <= 0.5):
        return None
    levels = simulation.levels
    factors = levels.factors(d.grid, xv)
    k = 2 ** tolerance.doublings(float(ratios.max()))
    if missed:
        return replace(d.grid, refinement=2 * d.refinement, factors=tuple(int(f) for f in 2 * factors))
    refinement, refined = d.refinement, factors
    if ratios[:len(names)].max() > 0.5:
        duration = t_end(simulation, settings)
        count = d.half_steps.steps
        x = np.ones(simulation.n_design) if xv is None else xv
        shares = indicator.shares(levels.at(d.half_steps, xv), x, list(names), {"newton": "modified", **settings,
                                  "t_end": duration}, np.full(count, duration / count), split)
        relative = sum(np.abs(shares.shares[n]) / max(abs(shares.coarse[n]), 1e-300) for n in names)
        refined = np.where(tolerance.dorfler(np.asarray(relative)), k * factors, factors)
    if ratios[len(names):].max(initial=0.0) > 0.5:
        refinement *= k
        refined = np.maximum(refined, levels.factors(Discretization(refinement, d.steps, floor=d.floor), xv))
    return replace(d.grid, refinement=refinement, factors=tuple(int(f) for f in refined))


def to_tolerance(simulation: Simulation, xv: np.ndarray | None, names: list[str], wanted: tuple[float, float],
                 settings: dict[str, Any], gradients: dict[str, str] | None, start: Discretization | None = None,
                 hold_gradients: bool = True, extrapolate: bool = False, made: Sequence[_Run] = (),
                 adjoint: bool = False) -> Any:
    """Runs until :func:`tolerance.resolve` accepts a candidate; returns the candidate's
    results (or sensitivities) with its estimate and companions attached. With
    ``gradients`` but not ``hold_gradients``, candidates are judged on forward runs and the
    sensitivities are computed once, on the grid accepted: of a dynamic run by the adjoint
    method about the candidate's run, not made again (but for ``method="direct"``). With ``gradients`` and
    ``extrapolate``, the sensitivities may be Richardson's extrapolation from the grid
    accepted and its half steps (:func:`extrapolated`), where that is the more accurate by
    the estimate: the half-steps run is made again at the run's own Newton tolerance
    (unless a candidate made it), so that the values are those of two ordinary runs, side
    by side (:func:`~flextop.execution.side_by_side`). Companion runs stop Newton at
    :func:`tolerance.companion_newton_tol` (unless the run's ``tol`` is given), and reuse
    any run made at their discretization; a candidate reuses only a candidate's run. With
    ``adjoint`` and the gradients held, a candidate's time errors are the adjoint's where they
    agree with its half steps (:func:`tolerance.agreed_time`). Judged on
    the values alone, a grid and steps one of the runs ``made`` already ran (of ``xv``: an
    optimization's trial on the grid held) are read from it, not run again."""
    duration = None if simulation.analysis == "static" else t_end(simulation, settings)
    if any(run.x is None or not np.array_equal(run.x, xv) for run in made):
        raise SettingsError("made: every run given must be of the design being run")
    levels = simulation.levels
    runs: dict[tuple[Discretization, bool], Any] = {}
    kept: dict[Discretization, Any] = {}  # the last companions' forward runs: the guides of space companions, the shares' states
    judged = gradients if hold_gradients else None
    loose = {"tol": tolerance.companion_newton_tol(wanted[0]), "newton": "modified"}
    loose = {k: v for k, v in loose.items() if k not in settings}

    def run(d: Discretization, gradients: dict[str, str] | None, is_companion: bool = False) -> Any:
        level = levels.at(d, xv)
        at = {**settings, **({"h": duration / d.steps, "t_end": duration} if d.steps else {}),
              **(loose if is_companion else {})}
        kept_states = is_split(d) or gradients is not None and gradients.get("memory") != "checkpoints"
        if gradients and is_companion and d.steps and gradients.get("method") != "direct" and kept_states:
            states = forward(d, level, at)  # kept for a guide or the shares; the gradients about them
            return level.sensitivities_fixed(xv, names, {**states.settings, **gradients}, about=states)
        if gradients:
            return level.sensitivities_fixed(xv, names, {**at, **gradients})
        return forward(d, level, at) if is_companion else level.run_fixed(xv, at)

    def is_split(d: Discretization) -> bool:
        return d.steps > 0 and d.uniform % 2 == 0

    def forward(d: Discretization, level: Simulation, at: dict[str, Any]) -> Any:
        """A companion's forward run, a space companion's guided by the run with half its
        elements (its half-steps companion, or the space companion it confirms), kept for
        the companion it may guide and for the shares: the last four."""
        coarser = replace(d, uniform=d.uniform // 2)
        coarse = (kept.get(coarser) or (None if judged else found(coarser))) if is_split(d) else None
        plain = {k: v for k, v in at.items() if k != "newton" or "newton" in settings}
        out = kept[d] = companion(level, xv, at, plain, coarse)
        while len(kept) > 4:
            kept.pop(next(iter(kept)))
        return out

    def found(d: Discretization, is_companion: bool = True) -> Any:
        return runs.get((d, False)) or (runs.get((d, True)) if is_companion else None)

    peaked = [n for n in names if n.split(":", 1)[0] in PEAK_LIMITED]

    def given(d: Discretization) -> Any:
        """The run of ``made`` on ``d``'s grid and steps, if any."""
        level = levels.at(d, xv) if made and d.steps else None
        return next((r for r in made if r.simulation is level and math.isclose(r.settings.get("h", 0.0), duration / d.steps,
                                                                                 rel_tol=1e-12)), None)

    def values(d: Discretization, is_companion: bool) -> list[np.ndarray]:
        out = found(d, is_companion)
        if out is None and not judged:
            out = given(d)
            if out is not None:
                runs[(d, False)] = out
        if out is None:
            out = runs[(d, is_companion)] = run(d, judged, is_companion)
        if judged:
            return [*out.values[:, None], *out.gradients, *(np.array([out.peaks[n]]) for n in peaked)]
        return [np.array([out.response(n)]) for n in names] + [np.array([out.peak(n)]) for n in peaked]

    tol = tolerance.tolerance_of(names, *wanted, judged is not None, peaked)
    measured = simulation.refine == "shares" and duration is not None
    d, est = tolerance.resolve(values, start or first(simulation, settings), tol, lambda d: levels.elements(d, xv),
                               extrapolate=extrapolate and gradients is not None,
                               mark=(lambda d, missed, ratios: marks(simulation, d, missed, ratios, xv, names, settings,
                                                                     kept.get(d.split)))
                               if measured else None,
                               adjoint=(lambda d: getattr(runs.get((d, False)), "time_errors", None))
                               if judged and adjoint else None)
    relative = list(map(float, est.relative))
    errors = dict(zip(names, relative))
    peak_errors = dict(zip(peaked, relative[len(relative) - len(peaked):]))
    if gradients:
        def with_gradients(at: Discretization) -> Any:
            kept = runs.get((at, False))
            if hold_gradients and kept is not None:
                return kept
            if kept is None or duration is None or gradients.get("method") == "direct":
                return run(at, gradients)
            return levels.at(at, xv).sensitivities_fixed(xv, names, {**kept.settings, **gradients}, about=kept)

        if d.extrapolated:  # the grid and its half steps side by side
            out = extrapolated(*side_by_side(lambda: with_gradients(d.grid), lambda: with_gradients(d.half_steps)))
        else:
            out = with_gradients(d.grid)
        held = relative[len(names):2 * len(names)] if hold_gradients else []
        return replace(out, discretization=d, errors=errors, gradient_errors=dict(zip(names, held)), peak_errors=peak_errors)
    out = runs[(d, False)]
    out.discretization, out.errors, out.peak_errors = d, errors, peak_errors
    out.companions = (found(d.half_steps), found(d.quarter_steps), found(d.split)) if d.steps else (None, None, found(d.split))
    return out
