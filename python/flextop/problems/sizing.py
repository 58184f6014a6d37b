"""Sizing problems on a spatial scene: the dimensions of its sections as the design,

    minimize f(z)   s.t.   r_j(z) ≤ b_j,   z_lo ≤ z ≤ z_hi,

each ``z_k`` a dimension of a named section (``"tube.outer"``, ``"blade.height"``; m) that
every beam and bar made of the section follows; the beams' densities ``x`` are held. The
optimizers see ``f0 = f / f_ref`` and ``g_j = r_j / b_j − 1``, ``f_ref`` the objective at
the first design evaluated unless given.

Responses are those of :meth:`SpatialSimulation.run_with_sensitivities` by name, their
gradients the engine's exact ones to each beam's section sizes (``outer:BEAM`` …) summed
over the section's beams; and ``mass``, ``Σ m(x_b) ρ A L`` of the beams and bars (kg, as
:meth:`SpatialSimulation.mass`), whose rate is ``(A'/A) Σ m(x_b) ρ A L`` over the section's
beams. Each evaluation builds the scene at ``z``: a design the scene refuses (a tube's
inner diameter reaching its outer) or whose motion fails is an
:class:`~flextop.optimizers.EvaluationError`, which the optimizer steps back from.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ..errors import SceneError, SettingsError, SimulationError
from ..optimizers import Evaluation, EvaluationError, Problem
from ..scenes.spatial import SpatialScene
from ..spatial import NQ, SpatialSimulation, _as_spec

#: The dimensions of each section shape, by the names a scene gives them.
DIMENSIONS = {"circle": ("diameter",), "tube": ("outer", "inner"), "rectangle": ("width", "height")}


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
    ``sizes`` (``{"SECTION.DIMENSION": (lower, upper)}``, m) subject to ``constraints``, each
    a ``(response, upper bound)`` (``mass`` among them, kg), at the held densities ``x``
    (full density by default). The start :attr:`z0` is the scene's own sizes. ``settings``
    go to every run.

    Raises
    ------
    SettingsError
        For a size the scene's sections do not have, bounds that are not ``0 < lower <
        upper`` and finite or leave out the scene's own size, a section no beam is made of,
        a bound that is not positive and finite, or a reference that is not.
    """

    def __init__(self, scene: SpatialScene | dict | str, objective: str, constraints: Sequence[tuple[str, float]] = (), *,
                 sizes: Mapping[str, tuple[float, float]], x: Any = None, reference: float | None = None,
                 **settings: Any) -> None:
        self.spec = copy.deepcopy(_as_spec(scene))
        sections = self.spec.get("sections") or {}
        self.sizes = [self._size(sections, name, bounds) for name, bounds in sizes.items()]
        if not self.sizes:
            raise SettingsError("sizes: name at least one SECTION.DIMENSION with its bounds")
        for name, bound in constraints:
            if not (isinstance(bound, (int, float)) and np.isfinite(bound) and bound > 0.0):
                raise SettingsError(f"constraint {name!r}: the bound {bound!r} must be positive and finite")
        if reference is not None and not (np.isfinite(reference) and reference > 0.0):
            raise SettingsError(f"reference: {reference!r} must be positive and finite")
        super().__init__([lo for _, _, (lo, _) in self.sizes], [hi for _, _, (_, hi) in self.sizes],
                         len(constraints), [f"{name} ≤ {bound:.4g}" for name, bound in constraints])
        self.z0 = np.array([sections[s][d] for s, d, _ in self.sizes], dtype=float)
        self.objective, self.settings, self.reference = objective, settings, reference
        self.responses = [objective, *(name for name, _ in constraints)]
        self.bounds = np.array([bound for _, bound in constraints], dtype=float)
        sim = SpatialSimulation(self.spec)
        self.x = sim.design(x)
        self.beams = self._beams_of(sim)
        for section, dimension, _ in self.sizes:
            if not self.beams[section]:
                raise SettingsError(f"sizes: no beam is made of section {section!r}")
        self.parameters = [f"{d}:{beam}" for s, d, _ in self.sizes for beam in self.beams[s]]
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
        """The scene with the sizes ``z``."""
        spec = copy.deepcopy(self.spec)
        for (section, dimension, _), value in zip(self.sizes, z):
            spec["sections"][section][dimension] = float(value)
        return spec

    def mass(self, sim: SpatialSimulation) -> tuple[float, np.ndarray]:
        """``Σ m(x_b) ρ A L`` of ``sim``'s beams and bars (kg) and its rate to each size."""
        masses, _, _ = sim.model.masses(None if self.x is None else list(self.x))
        full, _, _ = sim.model.masses(None)
        factor = [m / f if f > 0 else 1.0 for m, f in zip(masses, full)]
        sections = sim.spec["sections"]
        rate = np.zeros(self.n)
        for k, (section, dimension, _) in enumerate(self.sizes):
            s = sections[section]
            made = sum(length * (1.0 if v is None else factor[v])
                       for length, v in (self.lengths[b] for b in self.beams[section]))
            rate[k] = area_rate(s, dimension) * s["rho"] * area(s) * made
        return sim.mass(self.x), rate

    def evaluate(self, z: np.ndarray) -> Evaluation:
        engine = [r for r in self.responses if r != "mass"]
        try:
            sim = SpatialSimulation(self.spec_at(z))
            values, gradients = self._engine(sim, engine)
        except (SceneError, SimulationError) as error:
            raise EvaluationError(str(error), np.asarray(z)) from error
        if "mass" in self.responses:
            values["mass"], gradients["mass"] = self.mass(sim)
        f, df = values[self.objective], gradients[self.objective]
        if self.reference is None:
            if not f > 0.0:
                raise SettingsError(f"{self.objective} is {f:.3g} at the start: give a positive reference")
            self.reference = float(f)
        r = np.array([values[name] for name in self.responses[1:]])
        dr = np.array([gradients[name] for name in self.responses[1:]]).reshape(self.m, self.n)
        return Evaluation(f / self.reference, r / self.bounds - 1.0, df / self.reference, dr / self.bounds[:, None])

    def _engine(self, sim: SpatialSimulation, responses: list[str]) -> tuple[dict, dict]:
        """The engine's ``responses`` of ``sim`` and their gradients to the sizes, each its
        section's beams' columns summed."""
        if not responses:
            return {}, {}
        run = sim.run_with_sensitivities(self.x, responses, self.parameters, method="adjoint", **self.settings)
        columns = np.cumsum([0] + [len(self.beams[s]) for s, _, _ in self.sizes])
        summed = np.add.reduceat(run.gradient, columns[:-1], axis=1)
        return dict(zip(responses, run.values)), dict(zip(responses, summed))

    def physical(self, evaluation: Evaluation) -> tuple[float, np.ndarray, np.ndarray]:
        """The objective, the constrained responses and the objective's gradient in their
        own units."""
        reference = 1.0 if self.reference is None else self.reference
        return (evaluation.f0 * reference, (evaluation.g + 1.0) * self.bounds, evaluation.df0 * reference)
