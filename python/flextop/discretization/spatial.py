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
within its budget. The run that passes is an ordinary run on one grid, so its gradients are
exact for the scheme that ran.

Every frame beam is refined alike (planar scenes' ``refine="uniform"``): a spatial bar's
own frequency, which grades a planar scene's bars, and its measured share of the error are
not built for spatial bars.

A node named inside a beam, ``BEAM[k]`` (the ``k``-th of its ``split − 1`` inner nodes),
is the same point of the beam in every candidate: ``BEAM[r·k]`` at ``r`` times its elements,
wherever the scene or a response names it.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import SceneError, SettingsError, ToleranceError
from . import tolerance
from .accuracy import split_by
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


@dataclass(frozen=True, order=True)
class EveryBeam(Discretization):
    """A spatial candidate: ``refinement · uniform`` times the elements of every frame beam
    and ``steps`` uniform steps (:class:`~.tolerance.Discretization`'s fields; no floor or
    factors: the beams are not graded)."""

    def __str__(self) -> str:
        steps = f" and {self.steps} steps" if self.steps else ""
        return f"{self.refinement * self.uniform}× the scene's elements of every frame beam{steps}"


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
                 start: Discretization | None = None) -> Accepted:
    """``responses`` of ``sim`` (a :class:`~flextop.spatial.SpatialSimulation`) at ``design``
    with their gradients to the densities and ``parameters``, on the first candidate whose
    estimate meets ``rtol·|f| + atol`` for every value and ``GRADIENT_FACTOR · rtol`` for every
    gradient (``wanted = (rtol, atol)``); ``static`` at the equilibrium, else over the motion
    of ``settings``' ``t_end`` (the scene's by default); the candidates from ``start`` (the
    scene's grid by default: its elements, its step). Companion runs stop Newton at
    :func:`.tolerance.companion_newton_tol` and keep each step's first factorization while
    it contracts over a motion (``newton = "modified"``: on the robot arm at x = 0.4, 16 %
    less time in all), unless ``settings`` give ``tol`` or ``newton``.

    Raises :class:`ToleranceError` where no candidate within the limits of
    :func:`.tolerance.resolve` meets the tolerance, or where a refined scene passes the
    engine's limits on a beam's elements or the nodes."""
    loose = {key: value for key, value in (("tol", tolerance.companion_newton_tol(wanted[0])), ("newton", "modified"))
             if key not in settings and not (static and key == "newton")}  # no modified Newton in spatial statics
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

    if start is None:
        start = EveryBeam(1, 0) if static else EveryBeam(1, tolerance.start(_scene_steps(sim, settings)).steps)
    tol = tolerance.tolerance_of(list(responses), *wanted, True)
    d, est = tolerance.resolve(values, start, tol, lambda d: float(d.refinement * d.uniform))
    relative = list(map(float, est.relative))
    accepted = made[(d, False)]
    return Accepted(accepted, d, dict(zip(responses, relative)), dict(zip(responses, relative[len(responses):])))


def on_grid(sim: Any, d: Discretization, design: list[float] | None, responses: Sequence[str],
            parameters: Sequence[str], static: bool, settings: dict[str, Any]) -> Any:
    """``responses`` of ``sim`` and their gradients on the grid ``d``: every frame beam's
    elements times ``d.refinement · d.uniform``, ``d.steps`` uniform steps over the run's
    ``t_end`` (an equilibrium where ``static``), ``settings`` those of the run."""
    factor = d.refinement * d.uniform
    at = {**settings, **({"h": _duration(sim, settings) / d.steps} if d.steps else {})}
    beams = frame_beams(sim.spec)
    names = [renamed_response(r, factor, beams) for r in responses]
    return _level(sim, factor).run_with_sensitivities(design, names, list(parameters), equilibrium=static, **at)


def _level(sim: Any, factor: int) -> Any:
    """``sim``'s scene with ``factor`` times the elements of every frame beam, built once and
    kept on ``sim``; without a tolerance of its own, so that it runs its own grid."""
    if factor == 1 and sim.rtol is None:
        return sim
    refined = sim.refined
    if factor not in refined:
        try:
            refined[factor] = type(sim)(refined_spec(sim.spec, factor))
        except SceneError as error:
            raise ToleranceError(f"the tolerance needs {factor}× the elements of every beam, past the engine's limits: "
                                 f"{error}") from None
    return refined[factor]


def _duration(sim: Any, settings: dict[str, Any]) -> float:
    value = settings.get("t_end", sim.model.options().get("t_end"))
    if value is None:
        raise SettingsError("t_end: give it in the scene's [simulation] table or to the run")
    return float(value)


def _scene_steps(sim: Any, settings: dict[str, Any]) -> int:
    """The steps of the scene's own step over the run's ``t_end`` (16 where it gives none)."""
    duration, h = _duration(sim, settings), sim.model.options().get("h")
    return math.ceil(duration / float(h) - 1e-9) if h else 16


__all__ = ["Accepted", "ErrorEstimate", "EveryBeam", "frame_beams", "on_grid", "refined_spec", "renamed", "to_tolerance"]
