"""Runs of a spatial scene to a tolerance: the contract of :mod:`.tolerance` on a
:class:`~flextop.spatial.SpatialSimulation`.

A candidate is a :class:`~.tolerance.Discretization` ``(r, n)``: ``r`` times the elements of
every frame beam (its ``split``; a truss bar stays one element, exact in its axial
behaviour) and ``n`` uniform steps over ``[0, t_end]`` (none at an equilibrium). Its error
is estimated by step doubling in time and in space as on planar scenes
(:func:`.tolerance.resolve`): companions on 2h and 4h, one with twice the elements of every
beam on 2h (and four times, below rtol 1e-2); a candidate whose estimate is over budget
gets more steps or elements, until every response and its gradient (to the densities and
to the parameters asked for, held to ``GRADIENT_FACTOR · rtol`` in the relative 2-norm) is
within its budget; in time, by the candidate's own adjoint sweep where it agrees with its
half steps, and a motion's candidate is judged on Richardson's extrapolation from its half
steps too, as on planar scenes. The run that passes is an ordinary run on one grid (or two,
at h and 2h, extrapolated), so its gradients are exact for the scheme that ran.

With ``refine="uniform"`` every frame beam is refined alike. With ``refine="bars"`` (the
default) a dynamic scene's beams are graded as a planar scene's bars (:mod:`.indicator`): each beam's
own lowest clamped–clamped frequency ``f_b`` over both bending planes and its mass ``M_b``
(``SpatialModel.beam_frequencies``, ``beam_masses``) give its need ``M_b / f_b²``; the beams
of the largest need get ``r`` times their elements, each factor 8 of need below halves that,
down to the candidate's ``floor``, through the scene's ``splits`` table.
On the spatial robot arm's ten designs (BENCHMARKS.md, "Spatial runs to a tolerance") the
graded grids were those of uniform refinement where the scene's elements sufficed, and 40 %
cheaper on the random design down to 0.05, with honest estimates.

With ``refine="shares"`` a candidate starts graded as with ``"bars"``; where a value's space
error takes more than half its budget, the beams whose measured shares of the change that
splitting every beam makes carry 80 % of it (:func:`beam_shares`, the dual-weighted
residuals of ``src/spatial/shares.rs``, on the candidate's half steps) double their
elements, as a planar scene's bars do (:func:`.refinement.marks`): a gradient's error
alone follows the a-priori grading, and where a marking missed every beam doubles.

A node named inside a beam, ``BEAM[k]`` (the ``k``-th of its ``split − 1`` inner nodes),
is the same point of the beam in every candidate: ``BEAM[r·k]`` at ``r`` times its elements,
wherever the scene or a response names it.
"""

from __future__ import annotations

import copy
import math
import re
import threading
from collections.abc import Sequence
from dataclasses import astuple, dataclass, field, replace
from typing import Any

import numpy as np

from ..errors import SceneError, SettingsError, ToleranceError
from ..execution import side_by_side
from . import indicator, tolerance
from .accuracy import split_by
from .refinement import GRADED_KEPT
from .tolerance import Discretization, ErrorEstimate

INNER = re.compile(r"^(?P<beam>.+)\[(?P<k>\d+)\]$")
"""A node inside a beam: ``BEAM[k]`` (a lattice's nodes, ``NAME[i,j,k]``, have commas)."""

NAMED_NODE = ("x", "y", "z", "tip_deflection")
"""Responses whose name after the colon is a node's (or a body's)."""


def frame_beams(spec: dict) -> set[str]:
    """The names of a spatial scene's frame beams — its beams' and its ground structures'
    bars (``NAME/bar{m}``) that are not truss bars — whose inner nodes a refinement renames."""
    beams = {b["name"] for b in spec.get("beams", []) if b.get("kind", "frame") == "frame"}
    lattices = {g["name"] for g in spec.get("ground_structures", []) if g.get("kind", "frame") == "frame"}
    return beams | {f"{g}/bar" for g in lattices}


def renamed(name: str, factor: int, beams: set[str]) -> str:
    """``name`` at ``factor`` times the elements of every frame beam: ``BEAM[k]`` →
    ``BEAM[factor·k]``, anything else unchanged."""
    found = INNER.match(name)
    if found is None or factor == 1:
        return name
    beam = found["beam"]
    lattice_bar = "/bar" in beam and beam[:beam.rindex("/bar") + 4] in beams and beam[beam.rindex("/bar") + 4:].isdigit()
    return f"{beam}[{factor * int(found['k'])}]" if beam in beams or lattice_bar else name


def graded_spec(spec: dict, splits: dict[str, int], factors: dict[str, int]) -> dict:
    """The spatial scene with each frame beam's elements, ``splits`` (its elements as built),
    times its own ``factors`` entry (those not named keep theirs), through the scene's
    ``splits`` table, every node it names inside a beam renamed to the same point."""
    spec = copy.deepcopy(spec)
    table = spec.setdefault("splits", {})
    table.update({name: splits[name] * factor for name, factor in factors.items() if factor != 1})

    def walk(value: Any) -> Any:
        if isinstance(value, str):
            return graded_name(value, factors)
        if isinstance(value, list):
            return [walk(v) for v in value]
        if isinstance(value, dict):
            return {k: walk(v) for k, v in value.items()}
        return value

    return {key: (value if key == "splits" else walk(value)) for key, value in spec.items()}


def graded_name(name: str, factors: dict[str, int]) -> str:
    """``name`` with beam ``BEAM``'s elements times ``factors[BEAM]``: ``BEAM[k]`` →
    ``BEAM[factor·k]``, anything else unchanged."""
    found = INNER.match(name)
    if found is None or found["beam"] not in factors:
        return name
    return f"{found['beam']}[{factors[found['beam']] * int(found['k'])}]"


def refined_spec(spec: dict, factor: int) -> dict:
    """The spatial scene with ``factor`` times the elements of every frame beam, every node
    it names inside a beam renamed to the same point (:func:`renamed`)."""
    beams = frame_beams(spec)

    def walk(value: Any) -> Any:
        if isinstance(value, str):
            return renamed(value, factor, beams)
        if isinstance(value, list):
            return [walk(v) for v in value]
        if isinstance(value, dict):
            return {k: walk(v) for k, v in value.items()}
        return value

    return walk(split_by(spec, factor))


def renamed_response(response: str, factor: int, beams: set[str]) -> str:
    """A response's name at ``factor`` times the elements: its node renamed (:func:`renamed`)."""
    kind, sep, rest = response.partition(":")
    return f"{kind}:{renamed(rest, factor, beams)}" if sep and kind in NAMED_NODE else response


REFINE = ("uniform", "bars", "shares")
"""How a spatial scene's runs to a tolerance refine its beams (module docs)."""


@dataclass(frozen=True, order=True)
class EveryBeam(Discretization):
    """A spatial candidate: ``refinement · uniform`` times the elements of every frame beam,
    or with ``graded`` the beams graded by their need (module docs: ``refinement`` on those
    that need most, at least ``floor``, times ``uniform``), and ``steps`` uniform steps
    (:class:`~.tolerance.Discretization`'s fields; no measured factors)."""

    graded: bool = field(default=False, compare=False)
    """Whether the beams are graded (the simulation's ``refine="bars"``); the description's."""

    def __str__(self) -> str:
        if self.factors:
            refined = sum(f > 1 for f in self.factors)
            every = f", times {self.uniform} on every frame beam" if self.uniform != 1 else ""
            steps = f" and {self.steps} steps" if self.steps else ""
            extrapolated = ", extrapolated from half the steps" if self.extrapolated else ""
            return (f"up to {max(self.factors)}× the scene's elements on the {refined} of {len(self.factors)} beams that "
                    f"measured shares of the error refined{every}{steps}{extrapolated}")
        if self.graded:
            return super().__str__()
        steps = f" and {self.steps} steps" if self.steps else ""
        extrapolated = ", extrapolated from half the steps" if self.extrapolated else ""
        return f"{self.refinement * self.uniform}× the scene's elements of every frame beam{steps}{extrapolated}"


def saved(d: EveryBeam) -> list:
    """``d`` as a checkpoint holds it (:func:`restored` reads it back)."""
    return [*astuple(d)[:5], list(d.factors)]


def restored(sim: Any, data: Sequence) -> EveryBeam:
    """The candidate :func:`saved` wrote, on ``sim`` (a
    :class:`~flextop.spatial.SpatialSimulation`), graded as its runs grade."""
    refinement, steps, uniform, floor, extrapolated, factors = data
    graded = sim.refine in ("bars", "shares") and sim.analysis == "dynamic"
    return EveryBeam(refinement, steps, uniform, floor, extrapolated, tuple(factors), graded=graded, unit="frame beam")


def beam_factors(sim: Any, d: Discretization, design: list[float] | None) -> dict[str, int]:
    """Each frame beam's factor on its elements at candidate ``d`` for ``design``: those
    measured shares set (``d.factors``), or graded by need where ``sim.refine`` is
    ``"bars"`` or ``"shares"`` and the scene is dynamic, ``d.refinement`` on every one
    otherwise, at least ``d.floor``; times ``d.uniform``."""
    names = [name for name, _ in sim.model.beams]
    frame = np.isfinite(np.asarray(sim.model.beam_frequencies(None)))
    if d.factors:
        factors = d.uniform * np.asarray(d.factors, dtype=np.int64)
    else:
        frequencies = np.asarray(sim.model.beam_frequencies(design))
        dynamic = sim.refine in ("bars", "shares") and sim.analysis == "dynamic"
        graded = indicator.graded(frequencies, sim.model.beam_masses(design), d.refinement, dynamic)
        factors = d.uniform * np.maximum(d.floor, graded)
    return {name: int(f) for name, f, is_frame in zip(names, factors, frame) if is_frame}


@dataclass(frozen=True)
class Accepted:
    """What a run to a tolerance returns: the sensitivities of the grid accepted, the
    ``discretization`` and the estimated relative ``errors`` of the values and of their
    gradients (by response name)."""

    sensitivities: Any
    discretization: Discretization
    errors: dict[str, float]
    gradient_errors: dict[str, float]


def to_tolerance(sim: Any, design: list[float] | None, responses: Sequence[str], parameters: Sequence[str],
                 static: bool, wanted: tuple[float, float], settings: dict[str, Any],
                 start: Discretization | None = None, time_estimate: str = "adjoint", extrapolate: bool = True) -> Accepted:
    """``responses`` of ``sim`` (a :class:`~flextop.spatial.SpatialSimulation`) at ``design``
    with their gradients to the densities and ``parameters``, on the first candidate whose
    estimate meets ``rtol·|f| + atol`` for every value and ``GRADIENT_FACTOR · rtol`` for every
    gradient (``wanted = (rtol, atol)``); ``static`` at the equilibrium, else over the motion
    of ``settings``' ``t_end`` (the scene's by default); the candidates from ``start`` (the
    scene's grid by default: its elements, its step). Companion runs stop Newton at
    :func:`.tolerance.companion_newton_tol` and keep an iteration's factorization while it
    contracts (``newton = "modified"``: on the robot arm at x = 0.4, 16 % less time in all
    over a motion), unless ``settings`` give ``tol`` or ``newton``. ``time_estimate``: a
    candidate's time errors by its own adjoint where they agree with its half steps
    (``"adjoint"``, :func:`.tolerance.agreed_time`) or by step doubling alone
    (``"doubling"``). With ``extrapolate`` (a motion), a candidate is also judged on
    Richardson's extrapolation in the step from its half steps, as a planar scene's
    (:func:`.tolerance.extrapolated_estimate`): where that is the more accurate, the
    values, gradients and peaks returned are the extrapolation of the grid's run and its
    half steps' (both at the run's Newton tolerance), each gradient the exact derivative of
    its value, and the discretization says so.

    Raises :class:`ToleranceError` where no candidate within the limits of
    :func:`.tolerance.resolve` meets the tolerance, or where a refined scene passes the
    engine's limits on a beam's elements or the nodes."""
    loose = {key: value for key, value in (("tol", tolerance.companion_newton_tol(wanted[0])), ("newton", "modified"))
             if key not in settings}
    made: dict[tuple[Discretization, bool], Any] = {}

    def run(d: Discretization, companion: bool) -> Any:
        return on_grid(sim, d, design, responses, parameters, static, {**settings, **(loose if companion else {})})

    def values(d: Discretization, companion: bool) -> list[np.ndarray]:
        """The values and gradients of the run at ``d``: a candidate's own (at the run's
        Newton tolerance), or for a companion any run made there."""
        out = made.get((d, False)) or (made.get((d, True)) if companion else None)
        if out is None:
            out = made[(d, companion)] = run(d, companion)
        return [*out.values[:, None], *np.hstack([out.gradient, out.dfdx])]

    graded = sim.refine in ("bars", "shares") and not static
    if start is None:
        start = EveryBeam(1, 0) if static else EveryBeam(1, tolerance.start(_scene_steps(sim, settings)).steps,
                                                        graded=graded, unit="frame beam")
    tol = tolerance.tolerance_of(list(responses), *wanted, True)
    elements = np.array([len(ends) for _, ends in sim.model.beams], dtype=float)

    def cost(d: Discretization) -> float:
        """The candidate's elements over the scene's."""
        if not graded:
            return float(d.refinement * d.uniform)
        factors = np.array([beam_factors(sim, d, design).get(name, 1) for name, _ in sim.model.beams])
        return float(elements @ factors / max(1.0, elements.sum()))

    measured = sim.refine == "shares" and not static
    d, est = tolerance.resolve(values, start, tol, cost,
                               mark=(lambda d, missed, ratios: marks(sim, d, missed, ratios, design, responses, settings))
                               if measured else None,
                               extrapolate=extrapolate and not static,
                               adjoint=(lambda d: made[(d, False)].time_errors) if time_estimate == "adjoint" else None)
    relative = list(map(float, est.relative))
    accepted = made[(d.grid, False)]
    if d.extrapolated:  # the half steps again at the run's own Newton tolerance, unless a candidate made them
        half = made.get((d.half_steps, False)) or run(d.half_steps, False)
        accepted = extrapolated(accepted, half)
    return Accepted(accepted, d, dict(zip(responses, relative)), dict(zip(responses, relative[len(responses):])))


def extrapolated(fine: Any, half: Any) -> Any:
    """Spatial sensitivities at h and 2h on one grid combined by Richardson's extrapolation
    (:func:`.tolerance.richardson`): values, gradients to the parameters and densities, each
    the exact derivative of its extrapolated value, and peaks; no time error of its own."""
    def combined(at_h: np.ndarray, at_2h: np.ndarray) -> np.ndarray:
        return tolerance.richardson([np.asarray(at_h)], [np.asarray(at_2h)])[0]

    peaks = {name: float(combined(np.array(p), np.array(half.peaks[name]))) for name, p in fine.peaks.items()}
    return replace(fine, values=combined(fine.values, half.values), gradient=combined(fine.gradient, half.gradient),
                   dfdx=combined(fine.dfdx, half.dfdx), peaks=peaks, time_errors=None)


def marks(sim: Any, d: Discretization, missed: bool, ratios: np.ndarray, design: list[float] | None,
          responses: Sequence[str], settings: dict[str, Any]) -> Discretization | None:
    """The refinement after candidate ``d`` (``refine="shares"``), given each quantity's space
    error over its budget (``ratios``: the responses' values first), as a planar scene's
    :func:`.refinement.marks`: where a value's is over half of it, the beams whose shares
    (:func:`beam_shares` on ``d``'s half steps, relative to each value and summed over them)
    carry 80 % of it (:func:`.tolerance.dorfler`) double their elements, once or twice as
    the error asks (:func:`.tolerance.doublings`); where a gradient's is over, the a-priori
    grading's refinement doubles too and no beam has fewer elements than it gives; where the
    last marking ``missed``, every beam doubles. ``None`` for a scene with no frame beam, and
    where no value's error has marked a beam yet nor is over now."""
    n = len(responses)
    names = [name for name, _ in sim.model.beams]
    if not frame_beams(sim.spec) or (not d.factors and ratios[:n].max(initial=0.0) <= 0.5):
        return None
    current = beam_factors(sim, d.grid, design)
    factors = np.array([current.get(name, 1) for name in names], dtype=np.int64)
    k = 2 ** tolerance.doublings(float(ratios.max()))
    if missed:
        return replace(d.grid, refinement=2 * d.refinement, factors=tuple(int(f) for f in 2 * factors))
    refinement, refined = d.refinement, factors
    values = [r for r in responses if r.split(":")[0] not in MEASURED]
    if ratios[:n].max(initial=0.0) > 0.5 and values:
        duration, steps = _duration(sim, settings), d.half_steps.steps
        level, renamed = _scene_at(sim, d.half_steps, design, values)
        at = {"newton": "modified", **settings, "h": duration / steps, "t_end": duration}
        shares = beam_shares(level, design, renamed, at, refined_level(level, 2))
        relative = sum(np.abs(shares.shares[r]) / max(abs(shares.coarse[r]), 1e-300) for r in renamed)
        refined = np.where(tolerance.dorfler(np.asarray(relative)), k * factors, factors)
    if ratios[n:].max(initial=0.0) > 0.5:
        refinement *= k
        graded = beam_factors(sim, Discretization(refinement, d.steps, floor=d.floor), design)
        refined = np.maximum(refined, [graded.get(name, 1) for name in names])
    return replace(d.grid, refinement=refinement, factors=tuple(int(f) for f in refined))


MEASURED = ("volume", "mass")
"""Responses explicit in the design: no space error, no share."""


def beam_shares(sim: Any, design: list[float] | None, responses: Sequence[str], settings: dict[str, Any],
                fine: Any) -> indicator.Shares:
    """Each scene beam's share of the change of ``responses`` of ``sim`` (a
    :class:`~flextop.spatial.SpatialSimulation`) at ``design`` when every frame beam's
    elements are split in two, ``fine`` that scene (``src/spatial/shares.rs``): one run of
    each and two adjoint sweeps of ``sim``'s, with ``settings``. ``shares.shares[name]``
    follows ``sim.model.beams`` (a truss bar's is zero)."""
    beams = frame_beams(sim.spec)
    fine_names = [renamed_response(r, 2, beams) for r in responses]
    out = sim.model.beam_shares(fine.model, list(responses), fine_names, settings, design)
    return indicator.Shares(bars=tuple(name for name, _ in sim.model.beams),
                            shares={r: np.asarray(out["shares"][k]) for k, r in enumerate(responses)},
                            coarse={r: float(out["values"][k]) for k, r in enumerate(responses)},
                            fine={r: float(out["fine_values"][k]) for k, r in enumerate(responses)})


def on_grid(sim: Any, d: Discretization, design: list[float] | None, responses: Sequence[str],
            parameters: Sequence[str], static: bool, settings: dict[str, Any]) -> Any:
    """``responses`` of ``sim`` and their gradients on the grid ``d``: every frame beam's
    elements times its factor (:func:`beam_factors`), ``d.steps`` uniform steps over the
    run's ``t_end`` (an equilibrium where ``static``), ``settings`` those of the run; where
    ``d`` is extrapolated, the runs at its steps and its half steps, side by side
    (:func:`~flextop.execution.side_by_side`), combined (:func:`extrapolated`)."""
    level, names = _scene_at(sim, d, design, responses)
    if not d.extrapolated:
        return level.run_with_sensitivities(design, names, list(parameters), equilibrium=static, **_steps_of(sim, d, settings))
    made = [lambda at=at: level.run_with_sensitivities(design, names, list(parameters), equilibrium=static,
                                                       **_steps_of(sim, at, settings)) for at in (d.grid, d.half_steps)]
    return extrapolated(*side_by_side(*made))


def grid_of(sim: Any, d: Discretization, design: Any, settings: dict[str, Any]) -> tuple[Any, dict[str, Any]]:
    """The scene of ``sim`` refined as ``d`` says for ``design`` (each frame beam's elements
    times its factor) and the settings of a run on its steps: where a run to a tolerance
    accepted ``d``, what ran there."""
    level, _ = _scene_at(sim, d, None if design is None else list(map(float, design)), [])
    return level, _steps_of(sim, d, settings)


def _steps_of(sim: Any, d: Discretization, settings: dict[str, Any]) -> dict[str, Any]:
    """``settings`` with the step of ``d``'s uniform steps over the run (none for a static
    scene)."""
    return {**settings, **({"h": _duration(sim, settings) / d.steps} if d.steps else {})}


def _scene_at(sim: Any, d: Discretization, design: list[float] | None, responses: Sequence[str]) -> tuple[Any, list[str]]:
    """``sim``'s scene with each frame beam's elements as ``d`` says, and ``responses``
    named there."""
    factors = beam_factors(sim, d, design)
    if len(set(factors.values())) > 1:
        return _graded(sim, factors), [_graded_response(r, factors) for r in responses]
    factor = next(iter(factors.values()), d.refinement * d.uniform)
    beams = frame_beams(sim.spec)
    return refined_level(sim, factor), [renamed_response(r, factor, beams) for r in responses]


def _graded_response(response: str, factors: dict[str, int]) -> str:
    """A response's name with each beam's elements times its factor: its node renamed."""
    kind, sep, rest = response.partition(":")
    return f"{kind}:{graded_name(rest, factors)}" if sep and kind in NAMED_NODE else response


_KEPT = threading.Lock()
"""Guards the refined scenes kept on a simulation, which the threads of a pool share (a
scenario's simulation is this process's, :func:`flextop.simulation.cached`)."""


def _graded(sim: Any, factors: dict[str, int]) -> Any:
    """``sim``'s scene with each frame beam's elements times its ``factors`` entry, built once
    (outside the lock) and kept on ``sim`` among the :data:`~.refinement.GRADED_KEPT` most
    recently used."""
    key = tuple(factors.values())
    with _KEPT:
        found = sim.graded.get(key)
    if found is None:
        splits = {name: len(ends) for name, ends in sim.model.beams}
        try:
            found = type(sim)(graded_spec(sim.spec, splits, factors))
        except SceneError as error:
            raise ToleranceError(f"the tolerance needs up to {max(key)}× the elements of a beam, past the engine's "
                                 f"limits: {error}") from None
    with _KEPT:
        made = sim.graded
        found = made.setdefault(key, found)
        made.move_to_end(key)
        while len(made) > GRADED_KEPT:
            made.popitem(last=False)
    return found


def refined_level(sim: Any, factor: int) -> Any:
    """``sim``'s scene with ``factor`` times the elements of every frame beam, built once and
    kept on ``sim``; without a tolerance of its own, so that it runs its own grid."""
    if factor == 1 and sim.rtol is None:
        return sim
    with _KEPT:
        found = sim.refined.get(factor)
    if found is None:
        try:
            found = type(sim)(refined_spec(sim.spec, factor))
        except SceneError as error:
            raise ToleranceError(f"the tolerance needs {factor}× the elements of every beam, past the engine's limits: "
                                 f"{error}") from None
    with _KEPT:
        return sim.refined.setdefault(factor, found)


def _duration(sim: Any, settings: dict[str, Any]) -> float:
    value = settings.get("t_end", sim.model.options().get("t_end"))
    if value is None:
        raise SettingsError("t_end: give it in the scene's [simulation] table or to the run")
    return float(value)


def _scene_steps(sim: Any, settings: dict[str, Any]) -> int:
    """The steps of the scene's own step over the run's ``t_end`` (16 where it gives none)."""
    duration, h = _duration(sim, settings), sim.model.options().get("h")
    return math.ceil(duration / float(h) - 1e-9) if h else 16


__all__ = ["REFINE", "Accepted", "ErrorEstimate", "EveryBeam", "beam_factors", "beam_shares", "frame_beams", "graded_name",
           "graded_spec", "marks", "on_grid", "refined_level", "refined_spec", "renamed", "to_tolerance"]
