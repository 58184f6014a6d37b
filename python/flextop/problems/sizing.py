"""Sizing problems on a spatial scene: the dimensions of its sections and the places of its
joints as the design,

    minimize f(z)   s.t.   r_j(z) ≤ b_j,   z_lo ≤ z ≤ z_hi,

each ``z_k`` a dimension of a named section (``"tube.outer"``, ``"blade.height"``; m) that
every beam and bar made of the section follows, or a coordinate of a joint's place in
space where the scene builds it (``"pin.x"``; m), both its anchors' points moving with it in
their bodies; the beams' densities ``x`` are held, or designed too. The optimizers see
``f0 = f / f_ref`` and ``g_j = r_j / b_j − 1``, ``f_ref`` the objective at the first design
evaluated unless given. ``mass`` (``Σ m(x_b) ρ A L``, kg) and ``volume`` (``Σ x_b A L``, m³),
and ``mass:NAME`` and ``volume:NAME`` of a ground structure's designed bars, are explicit in
the design, their rates to a size ``A'/A`` over the section's beams at their densities.

With ``densities``, the beams' densities join the design after the sizes and places (each
in ``[x_min, 1]``, from ``x``): the sections' sizes, the joints' places and the topology in
one problem, every gradient from one run's adjoint sweep.

Held to a tolerance (``rtol``), the problem follows the planar and spatial problems' rule
(:mod:`.held`) on the design scaled to its bounds, ``(z − lower)/(upper − lower)``: an accepted
design that moved by more than ``readapt`` of a range is measured — the scene built at it
run to the tolerance (:func:`flextop.discretization.spatial.to_tolerance`, values and
gradients), from the grid measured last — and every other evaluation runs on that grid
(:func:`~flextop.discretization.spatial.on_grid`, each beam graded for the sizes at hand);
the design a run returns is measured as it ends.

Responses are those of :meth:`SpatialSimulation.run_with_sensitivities` by name, their
gradients the engine's exact ones to each beam's section sizes (``outer:BEAM`` …) summed
over the section's beams and to the joints' places (``position_x:JOINT`` …); the explicit
ones' above (as :meth:`SpatialSimulation.mass` and :meth:`~SpatialSimulation.volume`),
nothing to a place. Each
evaluation builds the scene at ``z``: a design the scene refuses (a tube's inner diameter
reaching its outer) or whose motion fails is an
:class:`~flextop.optimizers.EvaluationError`, which the optimizer steps back from.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ..checks import number
from ..discretization import spatial as spatial_tolerance
from ..discretization import tolerance
from ..discretization.tolerance import Discretization
from ..errors import DesignError, SceneError, SettingsError, SimulationError
from ..optimizers import Evaluation, EvaluationError, Problem
from ..scenes.spatial import SpatialScene
from ..quaternion import rotations
from ..spatial import MEASURES, NQ, SpatialSensitivities, SpatialSimulation, _as_spec
from .held import READAPT, Readapt

#: The dimensions of each section shape, by the names a scene gives them.
DIMENSIONS = {"circle": ("diameter",), "tube": ("outer", "inner"), "rectangle": ("width", "height")}


def _pairs(constraints: Any) -> list[tuple[str, float]]:
    """``constraints`` as ``(response, bound)`` pairs, or a :class:`SettingsError` naming the
    entry that is not one (its bound is checked apart)."""
    try:
        entries = list(constraints)
    except TypeError:
        raise SettingsError(f"constraints: give (response, bound) pairs, got {constraints!r}") from None
    for entry in entries:
        if not (isinstance(entry, (tuple, list)) and len(entry) == 2 and isinstance(entry[0], str)):
            raise SettingsError(f"constraint {entry!r}: give (response, bound)")
    return [(name, bound) for name, bound in entries]


def _mapping(what: str, given: Any) -> Mapping[str, Any]:
    """``sizes`` or ``places`` as given (``None``: none), or a :class:`SettingsError`."""
    if given is None:
        return {}
    if not isinstance(given, Mapping):
        raise SettingsError(f"{what}: give {{NAME: (lower, upper)}}, got {given!r}")
    return given


def area(section: Mapping[str, Any]) -> float:
    """A section's area (m²) from its shape and dimensions."""
    shape = section.get("shape", "circle")
    if shape == "circle":
        return math.pi * section["diameter"] ** 2 / 4
    if shape == "tube":
        return math.pi * (section["outer"] ** 2 - section["inner"] ** 2) / 4
    return section["width"] * section["height"]


def area_rate(section: Mapping[str, Any], dimension: str) -> float:
    """``A'/A`` of a section to one of its dimensions (1/m)."""
    shape, a = section.get("shape", "circle"), area(section)
    if shape == "circle":
        return 2 / section["diameter"]
    if shape == "tube":
        sign = 1.0 if dimension == "outer" else -1.0
        return sign * math.pi * section[dimension] / 2 / a
    return 1 / section[dimension]


class SizingProblem(Problem):
    """Minimize the response ``objective`` of the spatial ``scene`` over the section sizes
    ``sizes`` (``{"SECTION.DIMENSION": (lower, upper)}``, m) and the joints' places
    ``places`` (``{"JOINT.x": (lower, upper)}``, the joint's coordinate in space, m; ``y``,
    ``z`` likewise) subject to ``constraints``, each a ``(response, upper bound)`` (``mass``
    among them, kg), at the held densities ``x`` (full density by default), or with
    ``densities`` the densities designed too, from ``x``. The start :attr:`z0` is the scene's
    own sizes, then its joints' places, then (``densities``) ``x``. ``settings`` go to every
    run. ``rtol``, ``atol`` and ``readapt``: the tolerance every value and its gradient are
    held to and the rule that holds it (module docs; ``None``: the scene's grid).

    Raises
    ------
    SettingsError
        For a size the scene's sections do not have, bounds that are not ``0 < lower <
        upper`` and finite or leave out the scene's own size, a section no beam is made of;
        a joint the scene does not have, an axis that is not x, y or z, a joint that holds a
        node (a scene gives a node's anchor no point to move), bounds that are not finite
        with lower < upper or leave out the joint's place; a bound that is not positive and
        finite, or a reference that is not; a tolerance out of range, or ``h`` with one;
        ``densities`` on a scene whose every beam is fixed.
    DesignError
        For densities ``x`` that are not the scene's design.
    """

    def __init__(self, scene: SpatialScene | dict | str, objective: str, constraints: Sequence[tuple[str, float]] = (), *,
                 sizes: Mapping[str, tuple[float, float]] | None = None,
                 places: Mapping[str, tuple[float, float]] | None = None, x: Any = None, densities: bool = False,
                 reference: float | None = None, rtol: float | None = None, atol: float = 0.0,
                 readapt: float = READAPT, **settings: Any) -> None:
        number("atol", atol, 0.0, math.inf, "[)")  # checked where no rtol reads it too
        if rtol is not None:
            tolerance.check_tolerance(rtol, atol)
            if settings.get("h") is not None:
                raise SettingsError("give h (a fixed step) or rtol (steps chosen to meet it), not both")
        #: The tolerance every value and its gradient are held to (``None``: the scene's grid).
        self.tolerance = None if rtol is None else (float(rtol), float(atol))
        #: Where the error is measured (on the design scaled to its bounds), and the grid held since.
        self.rule, self.held = Readapt(readapt), None  # type: Readapt, Discretization | None
        if not isinstance(objective, str):
            raise SettingsError(f"objective: a response's name, got {objective!r}")
        constraints = _pairs(constraints)
        sizes, places = _mapping("sizes", sizes), _mapping("places", places)
        self.spec = copy.deepcopy(_as_spec(scene))
        sections = self.spec.get("sections") or {}
        self.sizes = [self._size(sections, name, bounds) for name, bounds in sizes.items()]
        sim = SpatialSimulation(self.spec)
        q = np.asarray(sim.model.initial_q)
        nodes = {name: k for k, name in enumerate(sim.model.node_names)}
        #: Each rigid body's centre (m) and axes in space at the start, what a place is read by.
        self._start = {b["name"]: (q[NQ * k:NQ * k + 3], rotations(q[NQ * k + 3:NQ * k + NQ][None])[0])
                       for b in self.spec.get("rigid_bodies", []) for k in [nodes[b["name"]]]}
        self.places = [self._place(name, bounds) for name, bounds in places.items()]
        #: The sizes' and places' bounds as given, by name (what a checkpoint rebuilds them from).
        self.given = {"sizes": {name: [*b] for name, (_, _, b) in zip(sizes, self.sizes)},
                      "places": {name: [*b] for name, (_, _, _, b) in zip(places, self.places)}}
        if not self.sizes and not self.places:
            raise SettingsError("sizes or places: name at least one SECTION.DIMENSION or JOINT.AXIS with its bounds")
        for name, bound in constraints:
            number(f"constraint {name!r}: the bound", bound, 0.0, math.inf, "()")
        if reference is not None:
            number("reference", reference, 0.0, math.inf, "()")
        bounds = [b for _, _, b in self.sizes] + [b for _, _, _, b in self.places]
        #: How many of the design's entries are sizes and places (the densities follow, where designed).
        self.k = len(bounds)
        self.x = sim.design(x)
        self.densities = bool(densities)
        if self.densities:
            if sim.n_design == 0:
                raise SettingsError("densities: every beam of the scene is fixed: no density to design")
            bounds += [(sim.x_min, 1.0)] * sim.n_design
        super().__init__([lo for lo, _ in bounds], [hi for _, hi in bounds],
                         len(constraints), [f"{name} ≤ {bound:.4g}" for name, bound in constraints])
        self.z0 = np.array([sections[s][d] for s, d, _ in self.sizes] + [at for _, _, at, _ in self.places], dtype=float)
        if self.densities:
            self.z0 = np.concatenate([self.z0, np.ones(sim.n_design) if self.x is None else self.x])
        self.objective, self.settings, self.reference = objective, settings, reference
        self.constraints = [(name, float(bound)) for name, bound in constraints]
        self.responses = [objective, *(name for name, _ in constraints)]
        self.bounds = np.array([bound for _, bound in constraints], dtype=float)
        self.beams = self._beams_of(sim)
        for section, dimension, _ in self.sizes:
            if not self.beams[section]:
                raise SettingsError(f"sizes: no beam is made of section {section!r}")
        self.parameters = [f"{d}:{beam}" for s, d, _ in self.sizes for beam in self.beams[s]]
        self.parameters += [f"position_{'xyz'[axis]}:{joint}" for joint, axis, _, _ in self.places]
        q = np.asarray(sim.model.initial_q)
        #: Each beam's length (m) and design variable (``None``: fixed), which no size moves.
        self.lengths = {name: (sum(float(np.linalg.norm(q[NQ * b:NQ * b + 3] - q[NQ * a:NQ * a + 3])) for a, b in ends), v)
                        for (name, ends), v in zip(sim.model.beams, sim.model.beam_variables)}

    @staticmethod
    def _size(sections: Mapping[str, Any], name: str, bounds: tuple[float, float]) -> tuple[str, str, tuple[float, float]]:
        section, _, dimension = str(name).partition(".")
        if section not in sections:
            raise SettingsError(f"sizes: {name!r}: no section called {section!r} (SECTION.DIMENSION)")
        shape = sections[section].get("shape", "circle")
        if dimension not in DIMENSIONS.get(shape, ()):
            raise SettingsError(f"sizes: {name!r}: a {shape} section has {', '.join(DIMENSIONS.get(shape, ()))}")
        try:
            lo, hi = (float(b) for b in bounds)
        except (TypeError, ValueError):
            raise SettingsError(f"sizes: {name!r}: bounds as (lower, upper) in m, got {bounds!r}") from None
        if not (np.isfinite(lo) and np.isfinite(hi) and 0.0 < lo < hi):
            raise SettingsError(f"sizes: {name!r}: bounds ({lo:g}, {hi:g}) must be finite with 0 < lower < upper")
        if not lo <= sections[section][dimension] <= hi:
            raise SettingsError(f"sizes: {name!r}: the scene's {sections[section][dimension]:g} m lies outside "
                                f"({lo:g}, {hi:g})")
        return section, dimension, (lo, hi)

    def _place(self, name: str, bounds: tuple[float, float]) -> tuple[str, int, float, tuple[float, float]]:
        """A place's joint, axis, coordinate at the start (m) and bounds, checked."""
        joint, _, axis = str(name).rpartition(".")
        entries = {j["name"]: j for j in self.spec.get("joints", [])}
        if joint not in entries:
            raise SettingsError(f"places: {name!r}: no joint called {joint!r} (JOINT.x, JOINT.y or JOINT.z)")
        if axis not in ("x", "y", "z"):
            raise SettingsError(f"places: {name!r}: the axis is x, y or z")
        entry, k = entries[joint], "xyz".index(axis)
        anchors = [entry.get(side, "ground") for side in ("a", "b")]
        for anchor in anchors:
            if isinstance(anchor, str) and anchor != "ground" and anchor.partition(".")[0] not in self._start:
                raise SettingsError(f"places: {name!r}: joint {joint!r} holds node {anchor!r}, whose anchor has no "
                                    "point a scene can move: hold it by a body's point")
        at = next(float(self._point(anchor)[k]) for anchor in anchors if anchor != "ground")
        try:
            lo, hi = (float(b) for b in bounds)
        except (TypeError, ValueError):
            raise SettingsError(f"places: {name!r}: bounds as (lower, upper) in m, got {bounds!r}") from None
        if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
            raise SettingsError(f"places: {name!r}: bounds ({lo:g}, {hi:g}) must be finite with lower < upper")
        # The place is read through the bodies' rotations: round-off off a bound it is on.
        slack = 1e-12 * max(1.0, abs(lo), abs(hi))
        if not lo - slack <= at <= hi + slack:
            raise SettingsError(f"places: {name!r}: the joint's {at:g} m lies outside ({lo:g}, {hi:g})")
        return joint, k, min(max(at, lo), hi), (lo, hi)

    def _point(self, anchor: Any) -> np.ndarray:
        """Where an anchor other than ``"ground"`` is at the start (m)."""
        if not isinstance(anchor, str):
            return np.asarray(anchor, dtype=float)
        body, _, point = anchor.partition(".")
        x, r = self._start[body]
        if not point:
            return np.array(x, dtype=float)
        points = next(b for b in self.spec["rigid_bodies"] if b["name"] == body).get("points", {})
        return x + r @ np.asarray(points[point], dtype=float)

    def _move(self, spec: dict, joint: str, axis: int, by: float) -> None:
        """Moves ``joint`` in ``spec`` by ``by`` (m) along ``axis``: each anchor's point in its
        body (a point of its own, so that what else the point holds stays), a ground point in
        space."""
        entry = next(j for j in spec["joints"] if j["name"] == joint)
        bodies = {b["name"]: b for b in spec["rigid_bodies"]}
        for side in ("a", "b"):
            anchor = entry.get(side, "ground")
            if anchor == "ground":
                continue
            if not isinstance(anchor, str):
                entry[side] = [float(c) + (by if i == axis else 0.0) for i, c in enumerate(anchor)]
                continue
            body, _, point = anchor.partition(".")
            points = bodies[body].setdefault("points", {})
            own = point if point.startswith(f"place:{joint}:") else f"place:{joint}:{side}"
            start = np.asarray(points.get(point, [0.0, 0.0, 0.0]), dtype=float)  # the centre: no point
            points[own] = [float(c) for c in start + self._start[body][1][axis] * by]
            entry[side] = f"{body}.{own}"

    def _beams_of(self, sim: SpatialSimulation) -> dict[str, list[str]]:
        """The scene's beams (a ground structure's bars among them) by section."""
        section_of = {b["name"]: b["section"] for b in self.spec.get("beams", [])}
        structures = {g["name"]: g["section"] for g in self.spec.get("ground_structures", [])}
        out: dict[str, list[str]] = {s: [] for s in self.spec.get("sections") or {}}
        for name, _ in sim.model.beams:
            section = section_of.get(name) or structures.get(name.split("/")[0])
            if section is not None:
                out[section].append(name)
        return out

    def spec_at(self, z: np.ndarray) -> dict:
        """The scene with the sizes and places ``z``."""
        spec = copy.deepcopy(self.spec)
        for (section, dimension, _), value in zip(self.sizes, z):
            spec["sections"][section][dimension] = float(value)
        for (joint, axis, at, _), value in zip(self.places, z[len(self.sizes):]):
            self._move(spec, joint, axis, float(value) - at)
        return spec

    @property
    def variables(self) -> list[str]:
        """The sizes' and places' names, in the design's order: ``SECTION.DIMENSION``, then
        ``JOINT.AXIS`` (the densities, where designed, follow them)."""
        return [f"{s}.{d}" for s, d, _ in self.sizes] + [f"{j}.{'xyz'[axis]}" for j, axis, _, _ in self.places]

    def densities_at(self, z: np.ndarray) -> np.ndarray | None:
        """The beams' densities at design ``z``: its own last entries where the densities are
        designed, else those held (``None``: full density)."""
        return np.asarray(z[self.k:], dtype=float) if self.densities else self.x

    def measured(self, sim: SpatialSimulation, response: str, x: np.ndarray | None) -> tuple[float, np.ndarray]:
        """A response explicit in the design — ``mass`` (``Σ m(x_b) ρ A L`` of the beams and
        bars, kg), ``volume`` (``Σ x_b A L``, m³), or ``mass:NAME``, ``volume:NAME`` (a ground
        structure's designed bars) — of ``sim`` at densities ``x``, and its rate to each
        entry of the design: ``A'/A`` times a section's share to its sizes, nothing to a
        place, the engine's to the densities."""
        kind, _, structure = response.partition(":")
        value, slopes = sim._measure(response, None if x is None else list(x))
        if kind == "mass":
            masses, _, _ = sim.model.masses(None if x is None else list(x))
            full, _, _ = sim.model.masses(None)
            share = [m / f if f > 0 else 1.0 for m, f in zip(masses, full)]  # m(x_b) of a variable's bars
        else:
            share = list(np.ones(sim.n_design) if x is None else x)
        sections = sim.spec.get("sections") or {}
        rate = np.zeros(self.n)
        for k, (section, dimension, _) in enumerate(self.sizes):
            s = sections[section]
            made = sum(length * (1.0 if v is None else share[v]) for b in self.beams[section]
                       for length, v in [self.lengths[b]] if not structure or (v is not None and b.startswith(f"{structure}/")))
            rate[k] = area_rate(s, dimension) * (s["rho"] if kind == "mass" else 1.0) * area(s) * made
        if self.densities:
            rate[self.k:] = slopes
        return value, rate

    def scaled(self, z: np.ndarray) -> np.ndarray:
        """``z`` on its bounds' ranges, ``(z − lower)/(upper − lower)``: what the tolerance rule
        measures a design's move on."""
        return (np.asarray(z, dtype=float) - self.lower) / (self.upper - self.lower)

    def evaluate(self, z: np.ndarray) -> Evaluation:
        """The responses at ``z``: on the scene's grid, or held to the tolerance — measured
        where no grid is held yet (or the caller never accepts and ``z`` moved), else on the
        grid held."""
        z = self._checked(z)
        return self._evaluated(z, self.tolerance is not None and self.rule.in_evaluate(self.scaled(z), self.held is not None))

    def _checked(self, z: Any) -> np.ndarray:
        """``z`` as a vector of this problem's :attr:`n` real numbers, or a :class:`DesignError`."""
        try:
            zv = np.asarray(z, dtype=float)
        except (TypeError, ValueError):
            raise DesignError(f"the design must be {self.n} real numbers, got {z!r}") from None
        if zv.shape != (self.n,):
            raise DesignError(f"the design has shape {zv.shape}; this problem has {self.n} variables")
        return zv

    def accept(self, z: np.ndarray, evaluation: Evaluation) -> Evaluation:
        """Held to a tolerance, the accepted design is measured where it moved by more than
        ``readapt`` of a range (its evaluation replaced)."""
        if self.tolerance is not None and self.rule.in_accept(self.scaled(z)):
            return self._evaluated(z, True)
        return evaluation

    def conclude(self, z: np.ndarray, evaluation: Evaluation) -> Evaluation:
        """Held to a tolerance, the design a run returns is measured unless it was the last
        measured."""
        if self.tolerance is not None and self.rule.in_conclude(self.scaled(z)):
            return self._evaluated(z, True)
        return evaluation

    def _evaluated(self, z: np.ndarray, measure: bool) -> Evaluation:
        explicit = [r for r in self.responses if r.split(":")[0] in MEASURES]
        engine = [r for r in self.responses if r not in explicit]
        x = self.densities_at(z)
        try:
            sim = SpatialSimulation(self.spec_at(z))
            values, gradients = self._engine(sim, engine, z, measure)
            for name in explicit:
                values[name], gradients[name] = self.measured(sim, name, x)
        except (SceneError, SimulationError) as error:
            raise EvaluationError(str(error), np.asarray(z)) from error
        f, df = values[self.objective], gradients[self.objective]
        if self.reference is None:
            if not f > 0.0:
                raise SettingsError(f"{self.objective} is {f:.3g} at the start: give a positive reference")
            self.reference = float(f)
        r = np.array([values[name] for name in self.responses[1:]])
        dr = np.array([gradients[name] for name in self.responses[1:]]).reshape(self.m, self.n)
        return Evaluation(f / self.reference, r / self.bounds - 1.0, df / self.reference, dr / self.bounds[:, None])

    def _engine(self, sim: SpatialSimulation, responses: list[str], z: np.ndarray, measure: bool) -> tuple[dict, dict]:
        """The engine's ``responses`` of ``sim`` (the scene at ``z``) and their gradients to
        the design — each size's its section's beams' columns summed, each place's, and
        the densities' where designed —: measured to the tolerance (the grid held from then
        on), on the grid held, or on the scene's grid."""
        if not responses:
            return {}, {}
        run = self._run(sim, responses, z, measure)
        columns = np.cumsum([0] + [len(self.beams[s]) for s, _, _ in self.sizes] + [1] * len(self.places))
        summed = np.add.reduceat(run.gradient, columns[:-1], axis=1)
        if self.densities:
            summed = np.hstack([summed, run.dfdx])
        return dict(zip(responses, run.values)), dict(zip(responses, summed))

    def _run(self, sim: SpatialSimulation, responses: list[str], z: np.ndarray, measure: bool) -> SpatialSensitivities:
        settings = {**self.settings, "method": "adjoint"}
        x = self.densities_at(z)
        design, static = None if x is None else list(x), sim.analysis == "static"
        if measure and self.tolerance is not None:
            accepted = spatial_tolerance.to_tolerance(sim, design, responses, self.parameters, static, self.tolerance,
                                                      settings, start=self.held)
            self.held = accepted.discretization
            self.rule.measured(self.scaled(z))
            return accepted.sensitivities
        if self.held is not None:
            return spatial_tolerance.on_grid(sim, self.held, design, responses, self.parameters, static, settings)
        return sim.run_with_sensitivities(x, responses, self.parameters, **settings)

    def to_dict(self) -> dict:
        """What rebuilds this problem (for checkpoints): the scene as given, the responses and
        bounds, the sizes' and places' bounds, the densities held, the reference, the
        settings, the tolerance with its rule and the grid held."""
        return {"scene": self.spec, "objective": self.objective, "constraints": [list(c) for c in self.constraints],
                **self.given, "x": None if self.x is None else self.x.tolist(), "densities": self.densities,
                "reference": self.reference,
                "settings": dict(self.settings), "tolerance": None if self.tolerance is None else list(self.tolerance),
                "rule": self.rule.to_dict(), "held": None if self.held is None else spatial_tolerance.saved(self.held)}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> SizingProblem:
        """The problem :meth:`to_dict` describes."""
        rtol, atol = data["tolerance"] if data.get("tolerance") is not None else (None, 0.0)
        problem = cls(data["scene"], data["objective"], [(name, bound) for name, bound in data["constraints"]],
                      sizes={k: tuple(v) for k, v in data["sizes"].items()},
                      places={k: tuple(v) for k, v in data["places"].items()}, x=data["x"],
                      densities=data.get("densities", False), reference=data["reference"],
                      rtol=rtol, atol=atol, readapt=data["rule"]["readapt"], **data["settings"])
        problem.rule = Readapt.from_dict(data["rule"])
        if data.get("held") is not None:
            problem.held = spatial_tolerance.restored(SpatialSimulation(problem.spec), data["held"])
        return problem

    def physical(self, evaluation: Evaluation) -> tuple[float, np.ndarray, np.ndarray]:
        """The objective, the constrained responses and the objective's gradient in their
        own units."""
        reference = 1.0 if self.reference is None else self.reference
        return (evaluation.f0 * reference, (evaluation.g + 1.0) * self.bounds, evaluation.df0 * reference)
